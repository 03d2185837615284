#include "evaluation/figure.h"

#include <cstdlib>
#include <sstream>

#include <sys/wait.h>

#include "io/atomic_file.h"
#include "util/log.h"

namespace lunarnav::evaluation {
namespace fs = std::filesystem;

std::string GnuplotString(const std::string& text) {
  std::string out = "\"";
  for (char c : text) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

FigureResult WriteFigure(const fs::path& dir, const std::string& name, const std::string& commands, int width,
                         int height) {
  FigureResult result;
  result.png = dir / (name + ".png");
  result.script = dir / (name + ".gp");
  // The script as shipped renders the final name from its own directory; the run here
  // renders a temporary name and renames it, so a failed run leaves no partial PNG.
  auto script = [&](const std::string& output) {
    std::ostringstream s;
    s << "# " << name << ".png from the CSV data beside it: gnuplot " << name << ".gp\n"
      << "set terminal pngcairo size " << width << "," << height << " font \"sans,10\"\n"
      << "set output " << GnuplotString(output) << "\n"
      << "set datafile separator \",\"\n"
      << "set datafile missing \"nan\"\n"
      << commands;
    if (commands.empty() || commands.back() != '\n') s << "\n";
    return s.str();
  };
  io::WriteFileAtomic(result.script, script(name + ".png"));

  const fs::path temp_png = io::TempPathFor(result.png);
  const fs::path temp_script = io::TempPathFor(result.script);
  io::WriteFileAtomic(temp_script, script(temp_png.filename().string()));
  const std::string command = "cd " + GnuplotString(dir.string()) + " && gnuplot " +
                              GnuplotString(temp_script.filename().string()) + " >/dev/null 2>&1";
  const int status = std::system(command.c_str());
  std::error_code ignored;
  fs::remove(temp_script, ignored);
  if (status != 0 || !fs::exists(temp_png)) {
    fs::remove(temp_png, ignored);
    result.problem = (WIFEXITED(status) && WEXITSTATUS(status) == 127)
                         ? "gnuplot not found (install gnuplot-nox); data and script written"
                         : "gnuplot failed; run it on " + result.script.filename().string() + " to see why";
    return result;
  }
  io::CommitTempFile(temp_png, result.png);
  result.rendered = true;
  return result;
}

nlohmann::json FigureSummary(const FigureResult& figure, const std::string& data_csv) {
  if (!figure.rendered) {
    LN_LOG(Warning) << figure.png.string() << ": not drawn: " << figure.problem;
  }
  return {{"png", figure.png.filename().string()},
          {"data", data_csv},
          {"rendered", figure.rendered},
          {"problem", figure.problem}};
}

}  // namespace lunarnav::evaluation
