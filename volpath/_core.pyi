"""
Volpath native core: scene model, tracers and render loop.
"""
from __future__ import annotations
import collections.abc
import enum
import numpy
import numpy.typing
import typing
__all__: list[str] = ['MeshFileError', 'RenderSettings', 'Scene', 'Tracer', 'TracerConfig', 'VoxelGrid', 'read_obj', 'read_ply', 'render']
class VoxelGrid:
    """
    A sparse voxel grid (8^3 bricks, empty ones not stored).
    """
    @staticmethod
    def from_bricks(res: typing.Annotated[collections.abc.Sequence[typing.SupportsInt | typing.SupportsIndex], "FixedSize(3)"], brick_index: typing.Annotated[numpy.typing.ArrayLike, numpy.int32], bricks: typing.Annotated[numpy.typing.ArrayLike, numpy.float32]) -> VoxelGrid:
        ...
    @staticmethod
    def from_dense(data: typing.Annotated[numpy.typing.ArrayLike, numpy.float32]) -> VoxelGrid:
        ...
    def dense(self) -> numpy.typing.NDArray[numpy.float32]:
        """
        The grid as a dense float32 array (z, y, x, c).
        """
    def lookup(self, p: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"]) -> typing.Annotated[list[float], "FixedSize(3)"]:
        """
        Trilinear lookup at a point of the unit cube.
        """
    @property
    def brick_index(self) -> numpy.typing.NDArray[numpy.int32]:
        ...
    @property
    def bricks(self) -> numpy.typing.NDArray[numpy.float32]:
        ...
    @property
    def channels(self) -> int:
        ...
    @property
    def nbytes(self) -> int:
        ...
    @property
    def res(self) -> typing.Annotated[list[int], "FixedSize(3)"]:
        ...
class Scene:
    def __init__(self) -> None:
        ...
    def __repr__(self) -> str:
        ...
    def add_box(self, to_world: typing.Annotated[numpy.typing.ArrayLike, numpy.float64], to_local: typing.Annotated[numpy.typing.ArrayLike, numpy.float64], flip_normals: bool, bsdf: typing.SupportsInt | typing.SupportsIndex, interior: typing.SupportsInt | typing.SupportsIndex = -1, exterior: typing.SupportsInt | typing.SupportsIndex = -1, medium_interface: bool = False, hidden_from: typing.SupportsInt | typing.SupportsIndex = 0) -> int:
        ...
    def add_bsdf_blend(self, a: typing.SupportsInt | typing.SupportsIndex, b: typing.SupportsInt | typing.SupportsIndex, weight: typing.SupportsFloat | typing.SupportsIndex) -> int:
        """
        (1 - weight) a + weight b (blendbsdf).
        """
    def add_bsdf_bumpmap(self, nested: typing.SupportsInt | typing.SupportsIndex, texture: typing.SupportsInt | typing.SupportsIndex, scale: typing.SupportsFloat | typing.SupportsIndex = 1.0, strength: typing.SupportsFloat | typing.SupportsIndex = 1.0) -> int:
        """
        The nested BSDF on the surface displaced by scale * texture(uv) along its normal.
        """
    def add_bsdf_conductor(self, eta: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], k: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], specular: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], alpha: typing.SupportsFloat | typing.SupportsIndex, twosided: bool = False) -> int:
        ...
    def add_bsdf_dielectric(self, eta: typing.SupportsFloat | typing.SupportsIndex, reflectance: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"] = [1.0, 1.0, 1.0], transmittance: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"] = [1.0, 1.0, 1.0]) -> int:
        ...
    def add_bsdf_diffuse(self, reflectance: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], twosided: bool = False) -> int:
        ...
    def add_bsdf_mask(self, nested: typing.SupportsInt | typing.SupportsIndex, opacity: typing.SupportsFloat | typing.SupportsIndex) -> int:
        """
        The nested BSDF where opaque, else straight through (mask).
        """
    def add_bsdf_normalmap(self, nested: typing.SupportsInt | typing.SupportsIndex, texture: typing.SupportsInt | typing.SupportsIndex, strength: typing.SupportsFloat | typing.SupportsIndex = 1.0) -> int:
        """
        The nested BSDF about normals from a tangent-space normal map (a raw texture).
        """
    def add_bsdf_null(self) -> int:
        ...
    def add_bsdf_roughdielectric(self, eta: typing.SupportsFloat | typing.SupportsIndex, alpha: typing.SupportsFloat | typing.SupportsIndex, reflectance: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"] = [1.0, 1.0, 1.0], transmittance: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"] = [1.0, 1.0, 1.0]) -> int:
        ...
    def add_bsdf_roughplastic(self, diffuse: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], specular: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], alpha: typing.SupportsFloat | typing.SupportsIndex, eta: typing.SupportsFloat | typing.SupportsIndex, twosided: bool = False) -> int:
        ...
    def add_bsdf_thindielectric(self, eta: typing.SupportsFloat | typing.SupportsIndex) -> int:
        ...
    def add_directional_light(self, direction: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], irradiance: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], replace: typing.SupportsInt | typing.SupportsIndex = -1, hidden_from: typing.SupportsInt | typing.SupportsIndex = 0) -> int:
        ...
    def add_environment(self, scale: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], image: typing.Annotated[numpy.typing.ArrayLike, numpy.float32] | None, to_world: typing.Annotated[numpy.typing.ArrayLike, numpy.float64], to_local: typing.Annotated[numpy.typing.ArrayLike, numpy.float64], replace: typing.SupportsInt | typing.SupportsIndex = -1, hidden_from: typing.SupportsInt | typing.SupportsIndex = 0) -> int:
        ...
    def add_group(self) -> int:
        """
        A new, empty shape group (Mitsuba's shapegroup); its index.
        """
    def add_instances(self, groups: typing.Annotated[numpy.typing.ArrayLike, numpy.int32], to_world: typing.Annotated[numpy.typing.ArrayLike, numpy.float64]) -> None:
        """
        Instances of shape groups, one a transform (n, 4, 4): one call for a field of them.
        """
    def add_medium_atmosphere(self, center: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], planet_radius: typing.SupportsFloat | typing.SupportsIndex, top_radius: typing.SupportsFloat | typing.SupportsIndex, rayleigh: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], rayleigh_height: typing.SupportsFloat | typing.SupportsIndex, mie_scattering: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], mie_absorption: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], mie_height: typing.SupportsFloat | typing.SupportsIndex, g: typing.SupportsFloat | typing.SupportsIndex, ozone: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], pieces: typing.SupportsInt | typing.SupportsIndex = 4, sun_transmittance: str = 'table', free_flight: str = 'guided', sky_map: bool = True) -> int:
        ...
    def add_medium_grid(self, density: VoxelGrid, world_to_grid: typing.Annotated[numpy.typing.ArrayLike, numpy.float64], albedo_grid: VoxelGrid | None = None, albedo_world_to_grid: typing.Annotated[numpy.typing.ArrayLike, numpy.float64] | None = None, albedo: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"] = [1.0, 1.0, 1.0], scale: typing.SupportsFloat | typing.SupportsIndex = 1.0, g: typing.SupportsFloat | typing.SupportsIndex = 0.0, majorant_res: typing.SupportsInt | typing.SupportsIndex = 0, Le_grid: VoxelGrid | None = None, Le_world_to_grid: typing.Annotated[numpy.typing.ArrayLike, numpy.float64] | None = None, Le_scale: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"] = [0.0, 0.0, 0.0]) -> int:
        ...
    def add_medium_homogeneous(self, sigma_a: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], sigma_s: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], g: typing.SupportsFloat | typing.SupportsIndex = 0.0, Le: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"] = [0.0, 0.0, 0.0]) -> int:
        ...
    def add_mesh(self, positions: typing.Annotated[numpy.typing.ArrayLike, numpy.float64], triangles: typing.Annotated[numpy.typing.ArrayLike, numpy.uint32], normals: typing.Annotated[numpy.typing.ArrayLike, numpy.float64] | None, bsdf: typing.SupportsInt | typing.SupportsIndex, interior: typing.SupportsInt | typing.SupportsIndex = -1, exterior: typing.SupportsInt | typing.SupportsIndex = -1, medium_interface: bool = False, radiance: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"] | None = None, uvs: typing.Annotated[numpy.typing.ArrayLike, numpy.float64] | None = None, hidden_from: typing.SupportsInt | typing.SupportsIndex = 0, emitter_twosided: bool = False, emitter_spread: typing.SupportsFloat | typing.SupportsIndex = 3.141592653589793, emitter_hidden_from: typing.SupportsInt | typing.SupportsIndex = 0, group: typing.SupportsInt | typing.SupportsIndex = -1, motion: typing.Annotated[numpy.typing.ArrayLike, numpy.float64] | None = None, emitter_texture: typing.SupportsInt | typing.SupportsIndex = -1) -> int:
        ...
    def add_point_light(self, position: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], intensity: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], replace: typing.SupportsInt | typing.SupportsIndex = -1, hidden_from: typing.SupportsInt | typing.SupportsIndex = 0) -> int:
        ...
    def add_sphere(self, center: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], radius: typing.SupportsFloat | typing.SupportsIndex, flip_normals: bool, bsdf: typing.SupportsInt | typing.SupportsIndex, interior: typing.SupportsInt | typing.SupportsIndex = -1, exterior: typing.SupportsInt | typing.SupportsIndex = -1, medium_interface: bool = False, radiance: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"] | None = None, hidden_from: typing.SupportsInt | typing.SupportsIndex = 0, emitter_twosided: bool = False, emitter_spread: typing.SupportsFloat | typing.SupportsIndex = 3.141592653589793, emitter_hidden_from: typing.SupportsInt | typing.SupportsIndex = 0, emitter_spot: tuple[typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], typing.SupportsFloat | typing.SupportsIndex, typing.SupportsFloat | typing.SupportsIndex] | None = None, emitter_soft_falloff: bool = False) -> int:
        ...
    def add_spot_light(self, position: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], direction: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], half_angle: typing.SupportsFloat | typing.SupportsIndex, blend: typing.SupportsFloat | typing.SupportsIndex, intensity: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], replace: typing.SupportsInt | typing.SupportsIndex = -1, hidden_from: typing.SupportsInt | typing.SupportsIndex = 0) -> int:
        """
        A point light whose light leaves within a cone (half_angle in radians), its outer `blend` share fading by a smoothstep (Blender's spot lamp).
        """
    def add_sun(self, to_sun: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], angular_radius: typing.SupportsFloat | typing.SupportsIndex, irradiance: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], replace: typing.SupportsInt | typing.SupportsIndex = -1, hidden_from: typing.SupportsInt | typing.SupportsIndex = 0) -> int:
        ...
    def add_texture_bitmap(self, texels: numpy.ndarray, srgb: bool, bilinear: bool = True, wrap: str = 'repeat', to_uv: typing.Annotated[numpy.typing.ArrayLike, numpy.float64] | None = None) -> int:
        """
        An image texture from texels (height, width, channels): uint8 (sRGB-encoded if srgb) or float (linear).
        """
    def add_texture_checkerboard(self, color0: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], color1: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], to_uv: typing.Annotated[numpy.typing.ArrayLike, numpy.float64] | None = None) -> int:
        ...
    def bind_texture(self, bsdf: typing.SupportsInt | typing.SupportsIndex, name: str, texture: typing.SupportsInt | typing.SupportsIndex, scale: typing.Annotated[numpy.typing.ArrayLike, numpy.float64], offset: typing.Annotated[collections.abc.Sequence[typing.SupportsFloat | typing.SupportsIndex], "FixedSize(3)"], squared: bool = False) -> None:
        """
        Makes a BSDF parameter offset + scale @ texture(uv) (squared if asked).
        """
    def build(self) -> None:
        ...
    def replace_bsdf(self, bsdf: typing.SupportsInt | typing.SupportsIndex) -> None:
        """
        Gives BSDF `bsdf` the parameters of the last one added, which is taken off (a material's values at an animation's frame; a leaf BSDF without textures).
        """
    def set_camera(self, to_world: typing.Annotated[numpy.typing.ArrayLike, numpy.float64], tan_x: typing.SupportsFloat | typing.SupportsIndex, tan_y: typing.SupportsFloat | typing.SupportsIndex, width: typing.SupportsInt | typing.SupportsIndex, height: typing.SupportsInt | typing.SupportsIndex, near_clip: typing.SupportsFloat | typing.SupportsIndex, far_clip: typing.SupportsFloat | typing.SupportsIndex, medium: typing.SupportsInt | typing.SupportsIndex, gaussian: bool, shift_x: typing.SupportsFloat | typing.SupportsIndex = 0.0, shift_y: typing.SupportsFloat | typing.SupportsIndex = 0.0, motion: typing.Annotated[numpy.typing.ArrayLike, numpy.float64] | None = None) -> None:
        ...
    def set_group_mesh(self, shape: typing.SupportsInt | typing.SupportsIndex, positions: typing.Annotated[numpy.typing.ArrayLike, numpy.float64], triangles: typing.Annotated[numpy.typing.ArrayLike, numpy.uint32], normals: typing.Annotated[numpy.typing.ArrayLike, numpy.float64] | None = None, uvs: typing.Annotated[numpy.typing.ArrayLike, numpy.float64] | None = None, motion: typing.Annotated[numpy.typing.ArrayLike, numpy.float64] | None = None) -> None:
        """
        Replaces a shape group's mesh (a deformed mesh at an animation's frame); build() then rebuilds that group's BVH and refits the scene's.
        """
    def set_instance_motion(self, instance: typing.SupportsInt | typing.SupportsIndex, keys: typing.Annotated[numpy.typing.ArrayLike, numpy.float64]) -> None:
        """
        Instance k's motion over the shutter: its to_world at evenly spaced times from the shutter's opening to its closing (K >= 2, 4, 4), interpolated linearly between them (motion blur).
        """
    def set_instances(self, instances: typing.Annotated[numpy.typing.ArrayLike, numpy.int32], to_world: typing.Annotated[numpy.typing.ArrayLike, numpy.float64]) -> None:
        """
        Moves instances (an animation's frame): their indices, in the order added, and new maps (n, 4, 4). build() then refits the BVH.
        """
    @property
    def height(self) -> int:
        ...
    @property
    def light_count(self) -> int:
        ...
    @property
    def memory(self) -> dict:
        ...
    @property
    def width(self) -> int:
        ...
class Tracer(enum.Enum):
    """
    The five tracers, each a superset of the one before (docs/tracers.md).
    """
    absorption = 0
    multiple = 2
    nee_mis = 3
    null_scattering = 4
    single = 1
    @classmethod
    def __new__(cls, value):
        ...
class TracerConfig:
    """
    Which tracer, and the bounds on its paths.
    """
    tracer: Tracer
    def __init__(self, *, tracer: Tracer = ..., max_depth: typing.SupportsInt | typing.SupportsIndex = -1, rr_depth: typing.SupportsInt | typing.SupportsIndex = 5, max_null_collisions: typing.SupportsInt | typing.SupportsIndex = 1000, light_distances: bool = True) -> None:
        ...
    def __repr__(self) -> str:
        ...
    @property
    def light_distances(self) -> bool:
        """
        NEE in homogeneous media also from distances drawn for the lights, combined by MIS.
        """
    @light_distances.setter
    def light_distances(self, arg0: bool) -> None:
        ...
    @property
    def max_depth(self) -> int:
        """
        Path segments as Mitsuba counts them: 1 = emitters seen directly, -1 = unlimited.
        """
    @max_depth.setter
    def max_depth(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    @property
    def max_null_collisions(self) -> int:
        """
        Safety cap on null collisions per path segment.
        """
    @max_null_collisions.setter
    def max_null_collisions(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    @property
    def rr_depth(self) -> int:
        """
        Scattering events before Russian roulette may end a path.
        """
    @rr_depth.setter
    def rr_depth(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
class RenderSettings:
    """
    What one call of render() takes besides the scene.
    """
    tracer: TracerConfig
    def __init__(self, *, spp: typing.SupportsInt | typing.SupportsIndex = 16, seed: typing.SupportsInt | typing.SupportsIndex = 0, first_sample: typing.SupportsInt | typing.SupportsIndex = 0, low_discrepancy: bool = True, threads: typing.SupportsInt | typing.SupportsIndex = 0, tracer: TracerConfig = ...) -> None:
        ...
    @property
    def first_sample(self) -> int:
        """
        Sample indices first_sample .. first_sample + spp - 1.
        """
    @first_sample.setter
    def first_sample(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    @property
    def low_discrepancy(self) -> bool:
        """
        Owen-scrambled Sobol; False: independent PCG32 numbers.
        """
    @low_discrepancy.setter
    def low_discrepancy(self, arg0: bool) -> None:
        ...
    @property
    def seed(self) -> int:
        """
        The same seed gives the same bits on any number of threads.
        """
    @seed.setter
    def seed(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    @property
    def spp(self) -> int:
        ...
    @spp.setter
    def spp(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
    @property
    def threads(self) -> int:
        """
        Worker threads (0: all hardware threads).
        """
    @threads.setter
    def threads(self, arg0: typing.SupportsInt | typing.SupportsIndex) -> None:
        ...
class MeshFileError(ValueError):
    pass
def read_obj(path: str) -> tuple:
    """
    (positions, triangles, normals or None, uvs or None) from a Wavefront OBJ file.
    """
def read_ply(path: str) -> tuple:
    """
    (positions, triangles, normals or None, uvs or None) from a PLY file (ASCII or binary).
    """
def render(scene: Scene, settings: RenderSettings, *, progress: typing.Any = None, out: typing.Any = None, starts: typing.Any = None, counts: typing.Any = None, halves: typing.Any = None, features: typing.Any = None) -> tuple:
    """
    Renders the scene: (image float32 (height, width, 3), stats dict). progress(fraction) is called from this thread about 20 times a second (False cancels). Adaptive rendering: pixel p takes counts[p] samples from first_sample + starts[p] on (uint32, (height, width)), summing even and odd samples into halves (float64, (height, width, 2, 3)); features (float64, (height, width, 8)) sums the first surface's albedo, normal, depth and hit count. Those arrays are written in place.
    """
