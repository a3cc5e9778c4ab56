"""Benchmarks print their section of bench/RESULTS.md and, with --append FILE, add it
there (Blender prints to stdout too, so redirecting output would not do)."""


def table(columns, rows):
    """A markdown table: its header of `columns`, then `rows` (lines already written)."""
    return f"| {' | '.join(columns)} |\n|{'---|' * len(columns)}\n" + "\n".join(rows) + "\n"


def publish(section, append=None):
    print(section)
    if append:
        with open(append, "a", encoding="utf-8") as f:
            f.write(section)
