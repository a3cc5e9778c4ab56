"""Benchmarks print their section of bench/RESULTS.md and, with --append FILE, add it
there (Blender prints to stdout too, so redirecting output would not do)."""


def publish(section, append=None):
    print(section)
    if append:
        with open(append, "a", encoding="utf-8") as f:
            f.write(section)
