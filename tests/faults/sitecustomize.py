"""The tests' fault injection: on PYTHONPATH (tests.faults.environment) this module runs
at the start of every Python process of a test's run, the pool's workers included, and
makes the frames listed in VOLPATH_TEST_FAIL_FRAMES fail to render."""

import os

_FAIL = {int(f) for f in os.environ.get("VOLPATH_TEST_FAIL_FRAMES", "").split(",") if f.strip()}

if _FAIL:
    import pipeline.frames

    _render_frame = pipeline.frames.render_frame

    def render_frame(source, frame, *args, **kwargs):
        if frame in _FAIL:
            raise RuntimeError(f"frame {frame}: failure injected by the tests")
        return _render_frame(source, frame, *args, **kwargs)

    pipeline.frames.render_frame = render_frame
