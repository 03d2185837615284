# Helpers of scripts/reproduce-paper (sourced, bash): a failing step stops the script, and each
# sentence of the results page that compares with the paper is printed from the measured
# numbers. awk and sed only (Debian's mawk is enough). Tested by tests/scripts/claims_test.sh.

# fail MESSAGE: one "error:" line on stderr, exit 1.
fail() { echo "error: $*" >&2; exit 1; }

# figure PNG DEST: a figure the page shows, copied to DEST; a figure that was not drawn fails.
figure() {
  [[ -s "$1" ]] || fail "$1: not drawn (see the step's log above)"
  cp "$1" "$2"
}

# col CSV KEY COLUMN: the value in column COLUMN (by header name) of the row whose first field
# is KEY (fields without commas, as evaluate's tables write them); fails when there is none.
col() {
  awk -F, -v key="$2" -v name="$3" 'NR == 1 { for (i = 1; i <= NF; ++i) if ($i == name) c = i; next }
    $1 == key { if (c) print $c; found = 1; exit } END { if (!found || !c) exit 1 }' "$1" ||
    fail "$1: no column $3 in row $2"
}

# colindex CSV COLUMN: the 1-based index of COLUMN in the CSV's header; fails when there is none.
colindex() {
  awk -F, -v name="$2" 'NR == 1 { for (i = 1; i <= NF; ++i) if ($i == name) { print i; found = 1 }; exit }
    END { if (!found) exit 1 }' "$1" || fail "$1: no column $2"
}

# verdict CONDITION: "reproduced" when the awk condition holds, else "not reproduced".
verdict() { if awk "BEGIN { exit !($1) }"; then echo "reproduced"; else echo "not reproduced"; fi; }

# calc EXPRESSION [FORMAT]: an awk expression printed with FORMAT (default %.3g).
calc() { awk "BEGIN { printf \"${2:-%.3g}\", $1 }"; }

# number KEY JSON: the first number stored under "KEY" in a JSON file; fails when there is none.
number() { sed -n "s/.*\"$1\": *\([0-9.eE+-]*\).*/\1/p" "$2" | head -1 | grep . || fail "$2: no $1"; }

# e_y_stats BOXES.csv (evaluate boxes' table with --rig): one line
#   "CELLS ABOVE SPREAD LAST_Y LAST_PREDICTED LAST_E|ABOVE_LIST|SPREAD_LIST"
# CELLS distances x runs; ABOVE the cells whose E_Y exceeds the 1-pixel prediction (listed in
# ABOVE_LIST); SPREAD the distances where E_Y's range over the runs exceeds half the prediction
# (listed in SPREAD_LIST); the last distance, its prediction and the first run's E_Y there.
e_y_stats() {
  awk -F, '
    NR == 1 { for (i = 1; i <= NF; ++i) { if ($i == "predicted_1px_m") p = i; if ($i ~ /^e_y_/) { e[++n] = i; name[n] = $i } } next }
    { for (k = 1; k <= n; ++k) {
        ++cells
        if ($(e[k]) + 0 > $p + 0) { ++above; run = name[k]; sub(/^e_y_/, "", run); sub(/_m$/, "", run)
          list = list sprintf("%s%s at %s m: %.3f m against %.3f m", (above > 1 ? "; " : ""), run, $1 + 0, $(e[k]), $p) }
        if (k == 1 || $(e[k]) + 0 > hi) hi = $(e[k]) + 0
        if (k == 1 || $(e[k]) + 0 < lo) lo = $(e[k]) + 0 }
      if (hi - lo > 0.5 * $p) { ++spread; slist = slist sprintf("%s%s m: %.3f-%.3f m", (spread > 1 ? "; " : ""), $1 + 0, lo, hi) }
      last_y = $1 + 0; last_p = $p + 0; last_e = $(e[1]) + 0 }
    END { printf "%d %d %d %s %s %s|%s|%s\n", cells, above + 0, spread + 0, last_y, last_p, last_e, list, slist }' "$1"
}
