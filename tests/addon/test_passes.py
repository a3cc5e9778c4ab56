"""Render passes for Blender's compositor: Depth and Denoising Albedo / Normal beside
Combined, as the view layer asks for them, against the passes volpath.render returns for
the exported scene."""

import numpy as np
from blender_scenes import bpy, depsgraph, small_scene

import volpath
from addon import engine
from addon.export import export_scene

SHOW = engine._show


def f12_passes(scene, monkeypatch):
    """F12, and the passes of the engine's render result as it hands it to Blender:
    {name: (h, w, channels)}, top row first."""
    seen = {}

    def show(result, image, aovs=None):
        SHOW(result, image, aovs)
        for p in result.layers[0].passes:
            values = np.empty(len(p.rect) * p.channels, np.float32)
            p.rect.foreach_get(values)
            seen[p.name] = values.reshape(scene.render.resolution_y, -1, p.channels)[::-1]

    monkeypatch.setattr(engine, "_show", show)
    bpy.ops.render.render()
    return seen


def test_f12_writes_the_passes_the_view_layer_asks_for(blank, monkeypatch):
    small_scene(blank)
    blank.volpath.seed, blank.volpath.spp = 3, 2
    layer = bpy.context.view_layer
    assert set(f12_passes(blank, monkeypatch)) == {"Combined"}  # nothing asked, nothing more
    layer.use_pass_z = True
    layer.volpath.denoising_data = True
    passes = f12_passes(blank, monkeypatch)
    assert set(passes) == {"Combined", "Depth", "Denoising Albedo", "Denoising Normal"}

    scene = volpath.load_dict(export_scene(depsgraph()).scene)
    image, aovs = volpath.render(scene, spp=2, seed=3, aovs=True)
    assert np.array_equal(passes["Combined"][..., :3], image)
    assert np.array_equal(passes["Denoising Albedo"], aovs["albedo"])
    assert np.array_equal(passes["Denoising Normal"], aovs["normal"])
    depth = passes["Depth"][..., 0]
    assert np.array_equal(depth, np.minimum(aovs["depth"], 1e10))
    # The floor and the sphere are in view, the sky above them is not.
    hit = np.isfinite(aovs["depth"])
    assert hit.any() and (depth[~hit] == 1e10).all() and (~hit).any()
    assert 0 < depth[hit].min() < depth[hit].max() < 100
