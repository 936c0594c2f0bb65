"""Issue 36, acceptance 3: the Liu (2007) reproduction report cannot go stale.

`scripts/liu2007_report.py --check` recomputes, with exactly the report's inputs, every row of
its tables (Ch. 2 with both pair models, Ch. 3, Ch. 4, the acceptance-2 checks), its notes and
the static-TE table (`CHECKED` in the script), and compares every geardyn value and verdict cell
with the printed `docs/validation/liu-2007.md`, character for character. The Ch. 2 sweeps come
from the pinned tables of the full run (`docs/validation/liu-2007/pinned/`), with every point a
row reads (and its neighbours on the branch) recorded again from its pinned state. The check
must pass on the committed report and fail on scratch copies where one printed number is
changed: one in the static-TE table, one in a Ch. 2 sweep row next to the mode-2 jump (all
reports in one run: the rows are computed once and compared with each report).
"""

import re
import subprocess
import sys

DOC = "docs/validation/liu-2007.md"


def bump_first_number(cell):
    """The cell with the last digit of its first number raised by one (9 wraps to 0)."""
    m = re.search(r"[0-9]+(\.[0-9]+)?", cell)
    digits = m.group(0)
    last = str((int(digits[-1]) + 1) % 10)
    return cell[:m.start()] + digits[:-1] + last + cell[m.end():]


def test_report_matches_recomputed_rows_and_detects_a_changed_number(repo_root, tmp_path,
                                                                    geardyn_bin):
    printed = (repo_root / DOC).read_text()
    # One number of the static-TE table: the first value of the 100 N·m line, raised by one in
    # its last printed digit.
    line = next(l for l in printed.splitlines() if l.startswith("| 100 | "))
    value = re.search(r"\| 100 \| ([0-9]+\.[0-9]{2}) ", line).group(1)
    changed = f"{float(value) + 0.01:.2f}"
    ste = tmp_path / "ste.md"
    ste.write_text(printed.replace(line, line.replace(f"| 100 | {value} ", f"| 100 | {changed} ", 1)))
    assert ste.read_text() != printed
    # One number of a Ch. 2 sweep row: the geometry pairs' peak mesh-1 force on the upper
    # branch at the mode-2 jump-down (a branch-sensitive point next to the jump).
    quantity = "Upper branch at the mode-2 jump-down: peak mesh-1 force"
    line = next(l for l in printed.splitlines() if f"| {quantity} |" in l)
    cells = line.split(" | ")
    cells[5] = bump_first_number(cells[5])
    sweep_row = tmp_path / "sweep_row.md"
    sweep_row.write_text(printed.replace(line, " | ".join(cells)))
    assert sweep_row.read_text() != printed

    proc = subprocess.run(
        [sys.executable, str(repo_root / "scripts" / "liu2007_report.py"), "--check",
         "--report", str(repo_root / DOC), "--report", str(ste), "--report", str(sweep_row)],
        capture_output=True, text=True, cwd=repo_root)
    print(proc.stderr)
    ok = re.search(r"; 0 differ from " + re.escape(str(repo_root / DOC)), proc.stderr)
    assert ok, f"the committed report is stale:\n{proc.stderr}"
    for scratch in (ste, sweep_row):
        bad = re.search(r"; ([0-9]+) differ from " + re.escape(str(scratch)), proc.stderr)
        assert bad and int(bad.group(1)) >= 1, proc.stderr
    assert "static-TE table differs" in proc.stderr
    assert f"{quantity} (geometry): now" in proc.stderr
    assert proc.returncode == 1
