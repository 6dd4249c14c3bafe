"""What the scripts that drive `drive-sim` share: where the measured data and the binary are, and
a runner that writes every command to OUT/commands.txt before running it and stops on the first
failure with its command and error output (so a table is never built on a missing result)."""
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
MEASURED = os.path.join(HERE, "..", "..", "shared", "data", "measured")
DEFAULT_BIN = os.path.join(HERE, "..", "target", "release", "drive-sim")


def write_table(out, header, rows, name="table.md"):
    """A markdown table of `header` (column titles) and `rows` (lines `| ... |`), printed and
    written to `out/name`."""
    table = ("| " + " | ".join(header) + " |\n|" + "---|" * len(header) + "\n" + "\n".join(rows) + "\n")
    with open(os.path.join(out, name), "w") as f:
        f.write(table)
    print(table)


class Runner:
    """Runs commands, each written to `out/commands.txt` first."""

    def __init__(self, out):
        os.makedirs(out, exist_ok=True)
        self.log = open(os.path.join(out, "commands.txt"), "w")

    def run(self, cmd):
        self.log.write(" ".join(cmd) + "\n")
        self.log.flush()
        r = subprocess.run(cmd, capture_output=True, text=True)
        if r.returncode != 0:
            sys.exit(f"failed ({r.returncode}): {' '.join(cmd)}\n{r.stderr}")
        return r
