"""Build scenes/sunrise/sunrise.blend, reproducibly, with the bpy module:

    python scenes/sunrise/build.py [output.blend]

A valley of rolling hills at dawn: standing stones and a lone tower cast long shadows,
a bank of fog (a procedural OpenVDB grid) lies in the valley, the camera stands 2 m
above the ground facing east, and a Sun lamp rises from 6 degrees below the horizon to
20 degrees above, drifting 8 degrees south, over the scene's frames. The world is a Sky
Texture, which Volpath renders as the physical atmosphere (Bruneton's constants).
Everything random comes from one seeded generator.
"""

import math
import os
import sys

import bpy
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, ROOT)

FRAMES = 72  # 3 s at 24 fps
rng = np.random.default_rng(2026)


def smooth_noise(shape, cells, rng):
    """Sum of bilinearly upsampled random lattices (value noise), in [0, 1]."""
    total = np.zeros(shape)
    for octave, amplitude in ((cells, 1.0), (cells * 2, 0.5), (cells * 4, 0.25)):
        lattice = rng.random((octave + 1,) * len(shape))
        coords = np.meshgrid(*(np.linspace(0, octave, n) for n in shape), indexing="ij")
        i = [np.minimum(c.astype(int), octave - 1) for c in coords]
        t = [c - k for c, k in zip(coords, i)]
        t = [x * x * (3 - 2 * x) for x in t]  # smoothstep
        if len(shape) == 2:
            a, b = i
            u, v = t
            total += amplitude * (
                (lattice[a, b] * (1 - u) + lattice[a + 1, b] * u) * (1 - v)
                + (lattice[a, b + 1] * (1 - u) + lattice[a + 1, b + 1] * u) * v
            )
        else:
            a, b, c = i
            u, v, w = t

            def lerp(x, y, s):
                return x * (1 - s) + y * s

            total += amplitude * lerp(
                lerp(
                    lerp(lattice[a, b, c], lattice[a + 1, b, c], u),
                    lerp(lattice[a, b + 1, c], lattice[a + 1, b + 1, c], u),
                    v,
                ),
                lerp(
                    lerp(lattice[a, b, c + 1], lattice[a + 1, b, c + 1], u),
                    lerp(lattice[a, b + 1, c + 1], lattice[a + 1, b + 1, c + 1], u),
                    v,
                ),
                w,
            )
    return total / 1.75


def principled(name, color, roughness=0.8, specular=0.5):
    m = bpy.data.materials.new(name)
    if m.node_tree is None:
        m.use_nodes = True
    bsdf = m.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*color, 1)
    bsdf.inputs["Roughness"].default_value = roughness
    bsdf.inputs["Specular IOR Level"].default_value = specular
    return m


def terrain():
    """4 km x 4 km: a valley running east along y = 0 between hills up to 150 m, and the
    knoll the camera stands on at its west end. Returns the height function."""
    n, size = 257, 4000.0
    x, y = np.meshgrid(np.linspace(-size / 2, size / 2, n), np.linspace(-size / 2, size / 2, n), indexing="ij")
    hills = 150 * smooth_noise((n, n), 5, rng)
    valley = 1 - np.exp(-((y / 450) ** 2))  # 0 on the valley floor, 1 on the hills
    knoll = 25 * np.exp(-((x + 300) ** 2 + y**2) / 160**2)
    height = hills * valley + 4 * smooth_noise((n, n), 20, rng) + knoll
    verts = np.stack([x, y, height], axis=-1).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(n - 1), np.arange(n - 1), indexing="ij")
    a = (i * n + j).ravel()
    faces = np.stack([a, a + n, a + n + 1, a + 1], axis=1)
    mesh = bpy.data.meshes.new("terrain")
    mesh.from_pydata(verts.tolist(), [], faces.tolist())
    mesh.shade_smooth()
    obj = bpy.data.objects.new("Terrain", mesh)
    bpy.context.collection.objects.link(obj)
    mesh.materials.append(principled("grass", (0.10, 0.16, 0.05), 0.9, specular=0.0))
    cell = size / (n - 1)

    def ground(px, py):
        return float(height[int(round((px + size / 2) / cell)), int(round((py + size / 2) / cell))])

    return ground


def stones(ground):
    """A ring of standing stones on the slope below the camera, a tower across the valley."""
    stone = principled("stone", (0.35, 0.33, 0.30), 0.7)
    for k in range(7):
        angle = 2 * math.pi * k / 7
        px, py = -250 + 11 * math.cos(angle), 11 * math.sin(angle)
        h = 3 + 2 * rng.random()
        bpy.ops.mesh.primitive_cube_add(
            size=1, location=(px, py, ground(px, py) + h / 2 - 0.3), rotation=(0, 0, rng.random() * math.pi)
        )
        obj = bpy.context.object
        obj.scale = (1.2, 0.6, h)
        obj.name = f"Stone.{k}"
        obj.data.materials.append(stone)
    bpy.ops.mesh.primitive_cylinder_add(radius=5, depth=30, location=(700, 180, ground(700, 180) + 13))
    bpy.context.object.name = "Tower"
    bpy.context.object.data.materials.append(stone)


def fog_bank(directory):
    """A 1.2 km x 0.6 km fog layer, densest at the valley floor, written as OpenVDB."""
    from addon.export.volumes import _openvdb

    vdb = _openvdb()
    nx, ny, nz, voxel = 240, 120, 16, 5.0
    noise = smooth_noise((nx, ny, nz), 6, rng)
    x, y, z = np.meshgrid(np.linspace(-1, 1, nx), np.linspace(-1, 1, ny), np.linspace(0, 1, nz), indexing="ij")
    edge = np.clip(1 - x**8 - y**4, 0, 1)
    density = np.clip(noise * 1.6 - 0.5, 0, None) * np.exp(-3 * z) * edge
    density[density < 0.02] = 0
    grid = vdb.FloatGrid()
    grid.name = "density"
    grid.copyFromArray(density.astype(np.float32))
    grid.transform = vdb.createLinearTransform(voxelSize=voxel)
    path = os.path.join(directory, "fog_bank.vdb")
    vdb.write(path, grids=[grid])
    bpy.ops.object.volume_import(filepath=path, location=(0, -ny * voxel / 2, 0))
    obj = bpy.context.object
    obj.name = "Fog"
    obj.data.filepath = "//fog_bank.vdb"
    m = bpy.data.materials.new("fog")
    if m.node_tree is None:
        m.use_nodes = True
    tree = m.node_tree
    out = tree.nodes["Material Output"]
    for link in list(out.inputs["Surface"].links):
        tree.links.remove(link)
    for node in [n for n in tree.nodes if n.bl_idname == "ShaderNodeBsdfPrincipled"]:
        tree.nodes.remove(node)
    pv = tree.nodes.new("ShaderNodeVolumePrincipled")
    pv.inputs["Density"].default_value = 0.01  # per metre: visibility of several hundred metres
    pv.inputs["Color"].default_value = (0.98, 0.98, 0.98, 1)
    pv.inputs["Anisotropy"].default_value = 0.6
    tree.links.new(pv.outputs[0], out.inputs["Volume"])
    obj.data.materials.append(m)


def sun_and_sky(scene):
    bpy.ops.object.light_add(type="SUN", location=(0, 0, 100))
    sun = bpy.context.object
    sun.name = "Sun"
    sun.data.energy = 20.0  # W/m² at the top of the atmosphere (scaled for display)
    sun.data.angle = math.radians(0.545)
    # The lamp shines along its -Z. Rotating by (90 - elevation) about Y turns -Z towards -X:
    # the light travels west, the sun stands in the east (+X); Z adds the drift to the south.
    for frame, elevation, azimuth in ((1, -6.0, 0.0), (FRAMES, 20.0, 8.0)):
        sun.rotation_euler = (0.0, math.radians(90 - elevation), math.radians(azimuth))
        sun.keyframe_insert("rotation_euler", frame=frame)
    world = bpy.data.worlds.new("Dawn")
    scene.world = world
    if world.node_tree is None:
        world.use_nodes = True
    tree = world.node_tree
    sky = tree.nodes.new("ShaderNodeTexSky")
    sky.sky_type = "MULTIPLE_SCATTERING"
    sky.altitude = 0.0
    tree.links.new(sky.outputs["Color"], tree.nodes["Background"].inputs["Color"])


def camera(scene, ground):
    px, py = -300.0, 0.0
    bpy.ops.object.camera_add(
        location=(px, py, ground(px, py) + 2.0), rotation=(math.radians(86), 0, math.radians(-90))
    )  # facing +X, east
    cam = bpy.context.object
    cam.name = "Camera"
    cam.data.lens = 28
    cam.data.clip_end = 10000
    scene.camera = cam


def main(path):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    import addon

    addon.register()
    scene = bpy.context.scene
    scene.name = "Sunrise"
    scene.render.engine = "VOLPATH"
    scene.frame_start, scene.frame_end = 1, FRAMES
    scene.render.fps = 24
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 320, 180, 100
    scene.view_settings.view_transform = "Standard"
    scene.volpath.spp = 16
    scene.volpath.tracer = "null_scattering"
    ground = terrain()
    stones(ground)
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    fog_bank(os.path.dirname(os.path.abspath(path)))
    sun_and_sky(scene)
    camera(scene, ground)
    bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath(path), compress=True)
    if os.path.exists(path + "1"):  # Blender's backup of an earlier build
        os.remove(path + "1")
    print(f"wrote {path}")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else os.path.join(HERE, "sunrise.blend"))
