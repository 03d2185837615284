// Parsing of the small value syntaxes used on command lines ("25x17", "44:118", "0/4").
#pragma once

#include <string>
#include <utility>

namespace lunarnav::util {

/// Parses "AxB" (e.g. "25x17") into two integers. Throws std::invalid_argument
/// naming `what` when the text is not of that form.
std::pair<int, int> ParseIntPair(const std::string& text, char separator, const std::string& what);

/// Parses "A:B" into two doubles. Throws std::invalid_argument naming `what`.
std::pair<double, double> ParseDoublePair(const std::string& text, char separator,
                                          const std::string& what);

/// Parses a whole string as an int / double (no trailing characters). Throws
/// std::invalid_argument naming `what`.
int ParseInt(const std::string& text, const std::string& what);
double ParseDouble(const std::string& text, const std::string& what);

/// `s` without its leading and trailing blanks, tabs and carriage returns (a CRLF file's lines).
std::string Trim(const std::string& s);

/// Removes a UTF-8 byte-order mark from the start of `first_line` (spreadsheets write one
/// before a CSV's first line): the text readers call it on a file's first line.
void DropUtf8Bom(std::string* first_line);

}  // namespace lunarnav::util
