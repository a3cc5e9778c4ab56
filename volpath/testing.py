"""Statistical helpers for Volpath's tests: chi-square goodness of fit of direction
samplers, and z-tests of images whose noise is estimated from independent renders."""

import numpy as np


def _sphere_bins(n_theta, n_phi):
    """Equal-area bins over the sphere: uniform in z = cos(theta) and in phi."""
    z_edges = np.linspace(-1, 1, n_theta + 1)
    phi_edges = np.linspace(-np.pi, np.pi, n_phi + 1)
    return z_edges, phi_edges


def chi2_directions(dirs, pdf, n_samples_valid, n_theta=20, n_phi=40, sub=12, z_marginal=None, axis=None):
    """Chi-square test of sampled unit directions against a density over the sphere.

    dirs: (n, 3) samples (failed samples already excluded).
    pdf:  callable (m, 3) -> (m,) solid-angle density of one sample.
    Expected counts come from integrating pdf over each bin with a sub x sub midpoint
    rule; bins expecting fewer than 5 samples are pooled. Returns the p-value.
    For densities symmetric about +z, z_marginal(z) (the density of z = cos theta)
    is integrated adaptively instead, which resolves sharply peaked lobes.
    axis: a direction to put on the equator of the bins (where they are best shaped),
    e.g. towards a small light, so the edges of a compact lobe cross few bins.
    """
    rotation = np.eye(3)
    if axis is not None:
        a = np.asarray(axis, float) / np.linalg.norm(axis)
        b = np.cross(a, [0.0, 0.0, 1.0] if abs(a[2]) < 0.9 else [1.0, 0.0, 0.0])
        b /= np.linalg.norm(b)
        rotation = np.stack([a, b, np.cross(a, b)])  # rows: a -> x, b -> y
        dirs = dirs @ rotation.T
        inner_pdf = pdf
        pdf = lambda d: inner_pdf(d @ rotation)
    z_edges, phi_edges = _sphere_bins(n_theta, n_phi)
    z = np.clip(dirs[:, 2], -1, 1)
    phi = np.arctan2(dirs[:, 1], dirs[:, 0])
    observed, _, _ = np.histogram2d(z, phi, bins=[z_edges, phi_edges])
    if z_marginal is not None:
        from scipy.integrate import quad

        pz = np.array(
            [
                quad(z_marginal, a, b, limit=200, epsabs=1e-12, epsrel=1e-10)[0]
                for a, b in zip(z_edges[:-1], z_edges[1:])
            ]
        )
        expected = np.repeat(pz[:, None] / n_phi, n_phi, axis=1) * n_samples_valid
        return chi2_pooled(observed.ravel(), expected.ravel())
    # Midpoint quadrature on each bin (each bin has solid angle dz * dphi).
    zc = (np.arange(n_theta * sub) + 0.5) / (n_theta * sub) * 2 - 1
    pc = (np.arange(n_phi * sub) + 0.5) / (n_phi * sub) * 2 * np.pi - np.pi
    Z, P = np.meshgrid(zc, pc, indexing="ij")
    r = np.sqrt(np.maximum(0, 1 - Z**2))
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
    # Many observations where nothing is expected mean the sampler and pdf disagree
    # (a few can be quadrature error at the edge of a lobe).
    if np.any((e <= 0) & (o > min_expected)):
        return 0.0
    keep = e > 0
    stat = np.sum((o[keep] - e[keep]) ** 2 / e[keep])
    dof = max(int(keep.sum()) - 1, 1)
    return float(chi2.sf(stat, dof))


# The standard errors come from the spread between batches, so a difference over them
# follows Student's t with (batches - 1) degrees of freedom, not the normal law: P(|t| > 5)
# is 1.5 % with 4 batches, 0.4 % with 6, 1.6e-4 with 16 (normal: 5.7e-7). Fewer batches
# asked for are spread over this many, with the same samples in all.
MIN_BATCHES = 16


def render_batches(render, scene, batches, block=1, spp=None, **kwargs):
    """Render the samples of `batches` images of `spp` samples each (default: the scene's)
    as at least MIN_BATCHES independent images (different seeds), average them over
    block x block pixel blocks, and return (mean, standard error of the mean): the
    error is estimated from the spread between the independent renders."""
    spp = scene.spp if spp is None else spp
    n = max(batches, MIN_BATCHES)
    per_batch = max(1, -(-batches * spp // n))
    images = np.stack(
        [
            block_means(np.asarray(render(scene, seed=1000 + i, spp=per_batch, **kwargs), np.float64), block)
            for i in range(n)
        ]
    )
    return images.mean(axis=0), images.std(axis=0, ddof=1) / np.sqrt(n)


def block_means(image, block):
    h, w = image.shape[:2]
    return image[: h - h % block, : w - w % block].reshape(h // block, block, w // block, block, -1).mean(axis=(1, 3))


def max_z(mean_a, se_a, mean_b, se_b, floor=1e-6):
    """Largest |a - b| / sqrt(se_a^2 + se_b^2) over all entries."""
    return float(np.max(np.abs(mean_a - mean_b) / np.sqrt(se_a**2 + se_b**2 + floor**2)))
