"""Small scenes built as XML strings for the tests."""

import numpy as np


def lookat(origin, target, up=(0, 1, 0)):
    """Mitsuba's lookat as a 4x4 camera to_world."""
    origin, target = np.asarray(origin, float), np.asarray(target, float)
    d = (target - origin) / np.linalg.norm(target - origin)
    left = np.cross(up, d)
    left /= np.linalg.norm(left)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = left, np.cross(d, left), d, origin
    return m


def camera(res=16, fov=40, origin="0, 0, 5", target="0, 0, 0", spp=16, medium=None, extra="", up="0, 1, 0"):
    med = f'<ref id="{medium}"/>' if medium else ""
    return f"""
    <sensor type="perspective">
        <float name="fov" value="{fov}"/>
        <transform name="to_world"><lookat origin="{origin}" target="{target}" up="{up}"/></transform>
        <sampler type="independent"><integer name="sample_count" value="{spp}"/></sampler>
        <film type="hdrfilm"><integer name="width" value="{res}"/><integer name="height" value="{res}"/>
            <rfilter type="box"/></film>
        {med}{extra}
    </sensor>"""


def scene(*parts, max_depth=-1):
    return f"""<scene version="3.0.0">
    <integrator type="volpath"><integer name="max_depth" value="{max_depth}"/></integrator>
    {"".join(parts)}
</scene>"""


def homogeneous(id_, sigma_t, albedo, g=0.0):
    phase = f'<phase type="hg"><float name="g" value="{g}"/></phase>' if g else '<phase type="isotropic"/>'
    return f"""<medium type="homogeneous" id="{id_}">
        <rgb name="sigma_t" value="{sigma_t}"/><rgb name="albedo" value="{albedo}"/>{phase}</medium>"""


def medium_sphere(id_, radius=1.0, center="0, 0, 0"):
    return f"""<shape type="sphere"><point name="center" value="{center}"/><float name="radius" value="{radius}"/>
        <bsdf type="null"/><ref name="interior" id="{id_}"/></shape>"""


def medium_cube(id_, half=1.0):
    return f"""<shape type="cube"><transform name="to_world"><scale value="{half}"/></transform>
        <bsdf type="null"/><ref name="interior" id="{id_}"/></shape>"""


def constant_env(radiance="1, 1, 1"):
    return f'<emitter type="constant"><rgb name="radiance" value="{radiance}"/></emitter>'


def back_light(z=-3, size=10, radiance="1, 1, 1"):
    return f"""<shape type="rectangle">
        <transform name="to_world"><scale value="{size}"/><translate z="{z}"/></transform>
        <emitter type="area"><rgb name="radiance" value="{radiance}"/></emitter></shape>"""


def area_light_above(y=3, size=0.5, radiance="20, 20, 20"):
    return f"""<shape type="rectangle">
        <transform name="to_world"><scale value="{size}"/><rotate x="1" angle="90"/><translate y="{y}"/></transform>
        <emitter type="area"><rgb name="radiance" value="{radiance}"/></emitter></shape>"""


def point_light(position="2, 2, 2", intensity="10, 10, 10"):
    return f'<emitter type="point"><point name="position" value="{position}"/><rgb name="intensity" value="{intensity}"/></emitter>'


def floor(y=-1, size=5, reflectance="0.5, 0.5, 0.5"):
    return f"""<shape type="rectangle">
        <transform name="to_world"><scale value="{size}"/><rotate x="1" angle="-90"/><translate y="{y}"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="{reflectance}"/></bsdf></shape>"""
