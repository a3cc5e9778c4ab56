"""Statistical helpers for Volpath's tests: chi-square goodness of fit of direction
samplers, and z-tests of images whose noise is estimated from independent renders."""

import numpy as np


def _sphere_bins(n_theta, n_phi):
    """Equal-area bins over the sphere: uniform in z = cos(theta) and in phi."""
    z_edges = np.linspace(-1, 1, n_theta + 1)
    phi_edges = np.linspace(-np.pi, np.pi, n_phi + 1)
    return z_edges, phi_edges


def chi2_directions(dirs, pdf, n_samples_valid, n_theta=20, n_phi=40, sub=12):
    """Chi-square test of sampled unit directions against a density over the sphere.

    dirs: (n, 3) samples (rows with a zero pdf are failed samples and excluded).
    pdf:  callable (m, 3) -> (m,) solid-angle density of one sample.
    Expected counts come from integrating pdf over each bin with a sub x sub midpoint
    rule; bins expecting fewer than 5 samples are pooled. Returns the p-value.
    """
    from scipy.stats import chi2

    z_edges, phi_edges = _sphere_bins(n_theta, n_phi)
    z = np.clip(dirs[:, 2], -1, 1)
    phi = np.arctan2(dirs[:, 1], dirs[:, 0])
    observed, _, _ = np.histogram2d(z, phi, bins=[z_edges, phi_edges])
    # Midpoint quadrature on each bin (each bin has solid angle dz * dphi).
    zc = (np.arange(n_theta * sub) + 0.5) / (n_theta * sub) * 2 - 1
    pc = (np.arange(n_phi * sub) + 0.5) / (n_phi * sub) * 2 * np.pi - np.pi
    Z, P = np.meshgrid(zc, pc, indexing="ij")
    r = np.sqrt(np.maximum(0, 1 - Z ** 2))
    grid = np.stack([r * np.cos(P), r * np.sin(P), Z], axis=-1).reshape(-1, 3)
    density = np.asarray(pdf(grid)).reshape(n_theta * sub, n_phi * sub)
    cell = (2.0 / (n_theta * sub)) * (2 * np.pi / (n_phi * sub))
    expected = density.reshape(n_theta, sub, n_phi, sub).sum(axis=(1, 3)) * cell * n_samples_valid
    return chi2_pooled(observed.ravel(), expected.ravel())


def chi2_pooled(observed, expected, min_expected=5.0):
    """Pearson chi-square with low-expectation bins pooled into one; returns the p-value."""
    from scipy.stats import chi2

    order = np.argsort(expected)
    obs, exp = observed[order], expected[order]
    small = exp < min_expected
    o = list(obs[~small])
    e = list(exp[~small])
    if small.any():
        o.append(obs[small].sum())
        e.append(exp[small].sum())
    o, e = np.array(o), np.array(e)
    # Observations where nothing is expected mean the sampler and pdf disagree.
    if np.any((e <= 0) & (o > 0)):
        return 0.0
    keep = e > 0
    stat = np.sum((o[keep] - e[keep]) ** 2 / e[keep])
    dof = max(int(keep.sum()) - 1, 1)
    return float(chi2.sf(stat, dof))


def render_batches(render, scene, batches, block=1, **kwargs):
    """Render `batches` independent images (different seeds), average them over
    block x block pixel blocks, and return (mean, standard error of the mean): the
    error is estimated from the spread between the independent renders."""
    images = np.stack([block_means(np.asarray(render(scene, seed=1000 + i, **kwargs), np.float64), block)
                       for i in range(batches)])
    return images.mean(axis=0), images.std(axis=0, ddof=1) / np.sqrt(batches)


def block_means(image, block):
    h, w = image.shape[:2]
    return image[: h - h % block, : w - w % block].reshape(h // block, block, w // block, block, -1).mean(axis=(1, 3))


def max_z(mean_a, se_a, mean_b, se_b, floor=1e-6):
    """Largest |a - b| / sqrt(se_a^2 + se_b^2) over all entries."""
    return float(np.max(np.abs(mean_a - mean_b) / np.sqrt(se_a ** 2 + se_b ** 2 + floor ** 2)))
