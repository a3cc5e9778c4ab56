"""Benchmarks print their section of bench/RESULTS.md and, with --append FILE, put it there
(Blender prints to stdout too, so redirecting output would not do): in place of the section
under the same key, so that the file holds the current figure for each question (git keeps
the ones it replaces), or at the end where there is none yet. A section runs from its marker,
``<!-- results: KEY -->``, to the next marker or the end of the file."""

import os

MARKER = "<!-- results: {} -->"
PREFIX = MARKER.split("{")[0]


def table(columns, rows):
    """A markdown table: its header of `columns`, then `rows` (lines already written)."""
    return f"| {' | '.join(columns)} |\n|{'---|' * len(columns)}\n" + "\n".join(rows) + "\n"


def publish(section, path=None, key=None):
    """Print `section`; with `path`, put it there under `key` (default: its first heading)."""
    print(section)
    if not path:
        return
    if key is None:
        key = next(line[3:].strip() for line in section.splitlines() if line.startswith("## "))
    block = MARKER.format(key) + "\n" + section.strip("\n") + "\n\n"
    try:
        with open(path, encoding="utf-8") as f:
            text = f.read()
    except FileNotFoundError:
        text = ""
    start = text.find(MARKER.format(key))
    if start < 0:
        text = text.rstrip("\n") + "\n\n" + block
    else:
        after = text.find(PREFIX, start + 1)
        text = text[:start] + block + (text[after:] if after >= 0 else "")
    tmp = f"{path}.tmp{os.getpid()}"
    with open(tmp, "w", encoding="utf-8") as f:
        f.write(text.rstrip("\n") + "\n")
    os.replace(tmp, path)
