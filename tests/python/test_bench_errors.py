"""bench/compare_mitsuba.py's errors are net of its reference's noise, and bench/ab.py's
time to equal error is variance x time: checked with fake renderers whose noise is known,
so that no render is needed."""

import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "bench"))
import ab  # noqa: E402
import compare_mitsuba  # noqa: E402

TRUE = np.linspace(0.1, 2.0, 64 * 64 * 3).reshape(64, 64, 3)


class NoisyRenderer:
    """The true image plus independent Gaussian noise of variance 1 / spp per pixel."""

    def render(self, spp, seed):
        rng = np.random.default_rng(seed)
        return TRUE + rng.normal(0.0, 1.0 / np.sqrt(spp), TRUE.shape), 0.0


def test_the_reference_variance_is_measured_and_taken_off():
    # Reference at 16 spp: variance 1/16, a quarter of the 4-spp image's 1/4, so an error
    # left uncorrected would be sqrt(1.25) = 1.12x the true one. 12288 pixel values give
    # each mean square a relative standard deviation of sqrt(2 / 12288) = 1.3 %: 5 % is
    # about 4 standard deviations for the sums and differences involved.
    ref, ref_var, _ = compare_mitsuba.reference(NoisyRenderer(), 16)
    assert abs(ref_var / (1 / 16) - 1) < 0.05
    img, _ = NoisyRenderer().render(4, 7)
    net = compare_mitsuba.rmse_net(compare_mitsuba.mse(img, ref), ref_var)
    assert abs(net / np.sqrt(1 / 4) - 1) < 0.05
    # An image as good as the reference cannot be told apart from it.
    assert compare_mitsuba.rmse_net(0.5 * ref_var, ref_var) is None


def test_ab_time_to_equal_error_is_variance_times_time():
    # Build B: half the variance, 1.5x the time per render: 0.75x the time to equal error.
    # 8 renders of 12288 pixel values: the mean variance is known to sqrt(2 / 7 / 12288) =
    # 0.5 % (relative), so 3 % is about 4 standard deviations of the ratio.
    rng = np.random.default_rng(5)
    a = [TRUE + rng.normal(0.0, 1.0, TRUE.shape) for _ in range(8)]
    b = [TRUE + rng.normal(0.0, np.sqrt(0.5), TRUE.shape) for _ in range(8)]
    var_a, t_a, cost_a = ab.time_to_equal_error(a, [1.0, 1.1, 0.9, 1.0, 5.0, 1.0, 1.0, 1.0])  # median: 1.0
    var_b, t_b, cost_b = ab.time_to_equal_error(b, [1.5] * 8)
    assert abs(var_a - 1) < 0.03 and t_a == 1.0 and t_b == 1.5
    assert abs(cost_b / cost_a - 0.75) < 0.03


def load_accuracy_study():
    import importlib.util

    path = os.path.join(os.path.dirname(__file__), "..", "..", "bench", "accuracy", "run.py")
    spec = importlib.util.spec_from_file_location("accuracy_run", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_accuracy_study_measures_net_errors_and_bias(tmp_path, monkeypatch):
    # bench/accuracy/run.py with the same fake renderer: options' "bias" adds a constant to
    # every pixel, which its bias estimate must find and an unbiased one must not.
    run = load_accuracy_study()
    monkeypatch.setattr(run, "CACHE", str(tmp_path))

    def render(study, res, options, kwargs, spp, seed):
        img, seconds = NoisyRenderer().render(spp, seed)
        return img + options.get("bias", 0.0), 1.0 * spp

    monkeypatch.setattr(run, "render", render)
    study = run.Study("fake", "", "", [])
    # The reference: spp from the 16-spp render's time (16 s here) and --ref-seconds: 256.
    ref, ref_var = run.reference(study, 64, seconds=256)
    assert abs(ref_var / (1 / 256) - 1) < 0.05
    again = run.reference(study, 64, seconds=256)  # cached, with its variance
    assert np.array_equal(again[0], ref) and again[1] == ref_var
    pts, bias = run.measure(study, 64, {}, {}, [4, 16], ref, ref_var)
    for spp, seconds, err in pts:
        assert seconds == spp and abs(err / np.sqrt(1 / spp) - 1) < 0.05
    # The bias estimate's own spread: its mean squares (about 1/32, the 16-spp pair's mean)
    # are each known to 1.3 %, their difference to about 6e-4, so a true bias of 0 reads
    # below sqrt(4 * 6e-4) = 0.05 but once in 30000 (four standard deviations).
    assert bias < 0.05
    _, bias = run.measure(study, 64, {"bias": 0.2}, {}, [4, 16], ref, ref_var)
    assert abs(bias - 0.2) < 0.02
    # Time to an error between the rungs' errors (0.5 at 4 s, 0.25 at 16 s): the fit's slope
    # is -0.5, so 0.3 takes (0.5 / 0.3)^2 * 4 = 11.1 s.
    assert abs(run.time_to(pts, 0.3, 0.0) / 11.1 - 1) < 0.1


def test_a_published_section_replaces_its_earlier_figure(tmp_path, capsys):
    """bench/RESULTS.md holds the current figure per question: a section published again
    under its key replaces the old one in place, others stay, a new key goes at the end."""
    from publish import publish

    path = tmp_path / "RESULTS.md"
    path.write_text("# Results\n\n<!-- results: a -->\n## A\nold a\n\n<!-- results: b -->\n## B\nb\n")
    publish("\n## A\nnew a\n", str(path), key="a")
    publish("## C\nc\n", str(path))  # keyed by its heading
    text = path.read_text()
    assert text.count("<!-- results: a -->") == 1 and "old a" not in text and "new a" in text
    assert text.index("new a") < text.index("## B") < text.index("<!-- results: C -->")
    assert text.startswith("# Results\n") and "new a" in capsys.readouterr().out
