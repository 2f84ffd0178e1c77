"""The scene schema (DESIGN.md section 6): the typed tables of a scene file, with units and ranges.

A scene file is validated into these dataclasses before anything is built (core/spec.py does the
checking: unknown keys, wrong types, NaN/inf and out-of-range values raise a ConfigError naming the
key path, the value and the allowed range). The full schema is documented in docs/scenes.md.
"""

from __future__ import annotations

import math
from dataclasses import MISSING, dataclass, fields

from core.errors import ConfigError
from core.spec import spec_field

EFFECTS = ("rigid", "fracture", "subdivision", "shatter", "elastic", "wpca", "debris")
# an effect that needs another: the key names the effect, the value what it needs
EFFECT_NEEDS = {"subdivision": "fracture", "shatter": "fracture", "debris": "shatter", "fracture": "rigid"}


def build_material(m: MaterialConfig, path: str, source: str):
    """The sph.materials.Material of a material table; its errors carry the key path and file."""
    from sph.materials import material_from_dict

    d = dict(m.stiffness)
    d.update(density=m.density, tensile_strength=m.tensile_strength, toughness=m.toughness,
             restitution=m.restitution, friction=m.friction, name=m.name)
    if m.cleavage:
        d["cleavage"] = m.cleavage
    try:
        return material_from_dict(d, key=f"{path}.stiffness")
    except ConfigError as exc:
        exc.source = source
        exc.args = (f"{source}: {exc.args[0]}",)
        raise


@dataclass
class KernelConfig:
    """The SPH kernel of a material (Sect. 4.1, Eq. 4-6)."""

    mode: str = spec_field("str", "isotropic", choices=("isotropic", "fixed", "wpca"))
    support: float = spec_field("float", 2.0, lo=1.0, hi=6.0, unit="x the object's resolution, its tet edge")
    axis_scale: list = spec_field("vec3", [1.0, 1.0, 1.0], lo=0.01, hi=100.0, unit="-")
    axes: list = spec_field("floats", [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0], length=9, lo=-1.0, hi=1.0)
    max_ratio: float = spec_field("float", 4.0, lo=1.0, hi=20.0, unit="-")


@dataclass
class MaterialConfig:
    name: str = spec_field("str")
    density: float = spec_field("float", lo=1.0, hi=30000.0, unit="kg/m^3")
    stiffness: dict = spec_field("dict")
    tensile_strength: float = spec_field("float", 1.0e7, lo=0.0, hi=1e11, lo_open=True, unit="Pa")
    toughness: float = spec_field("float", 10.0, lo=0.0, hi=1e7, lo_open=True, unit="J/m^2")
    restitution: float = spec_field("float", 0.2, lo=0.0, hi=1.0, unit="-")
    friction: float = spec_field("float", 0.5, lo=0.0, hi=10.0, unit="-")
    # weak planes (slate's cleavage, bedding): {normal = [x, y, z], tensile_strength = Pa} (sph/cleavage.py)
    cleavage: dict = spec_field("dict", {})
    kernel: KernelConfig = spec_field("table", KernelConfig(), table=KernelConfig)
    # N radial cracks per event (Algorithm 1's groups), or "auto": N from the plate's bending vs
    # fracture energy and the impact speed (sph/structure.py, star_crack_count)
    cracks: int | str = spec_field("int_or_auto", 3, lo=1, hi=32, unit="cracks per event")
    # how it looks in frames: color, roughness, opacity, crack_color (render/looks.py; defaults by kind)
    look: dict = spec_field("dict", {})

    def check(self, path: str, source: str) -> None:
        from render.looks import material_look

        self.elastic = build_material(self, path, source)  # validates the elastic constants now
        self.appearance = material_look(self.name, self.look, f"{path}.look", source)



@dataclass
class ObjectConfig:
    name: str = spec_field("str")
    material: str = spec_field("str")
    shape: dict = spec_field("dict", {})
    mesh: str = spec_field("str", "")
    units: str = spec_field("str", "")
    repair: bool = spec_field("bool", False)
    resolution: float = spec_field("float", 0.01, lo=1e-5, hi=10.0, unit="m")
    region_materials: dict = spec_field("dict", {})
    position: list = spec_field("vec3", [0.0, 0.0, 0.0], lo=-1e6, hi=1e6, unit="m")
    rotation: list = spec_field("vec3", [0.0, 0.0, 0.0], lo=-360.0, hi=360.0, unit="deg, XYZ Euler")
    velocity: list = spec_field("vec3", [0.0, 0.0, 0.0], lo=-1e3, hi=1e3, unit="m/s")
    angular_velocity: list = spec_field("vec3", [0.0, 0.0, 0.0], lo=-1e3, hi=1e3, unit="rad/s")
    breakable: bool = spec_field("bool", True)
    static: bool = spec_field("bool", False)
    group_size: int = spec_field("int", 4, lo=1, hi=16, unit="particles per boundary particle")
    fixed_box: list = spec_field("floats", [], lo=-1e6, hi=1e6, unit="m: min xyz, max xyz of fixed particles")
    held_border: float = spec_field("float", 0.0, lo=0.0, hi=100.0, unit="m: static breakable objects keep fragments "
                                    "within this distance of their bounding box's sides fixed (a window frame)")
    count: int = spec_field("int", 1, lo=1, hi=100, unit="copies")
    spacing: list = spec_field("vec3", [0.0, 0.0, 0.0], lo=-100.0, hi=100.0, unit="m between copies")

    def check(self, path: str, source: str) -> None:
        if bool(self.shape) == bool(self.mesh):
            raise ConfigError(f"{path}.shape", self.shape or self.mesh, "exactly one of 'shape' or 'mesh'", source)
        if self.mesh and not self.units:
            raise ConfigError(f"{path}.units", None, "the length unit of the mesh file (m, cm, mm, in, ...)", source)
        if self.fixed_box and len(self.fixed_box) != 6:
            raise ConfigError(f"{path}.fixed_box", self.fixed_box, "6 numbers: min x y z, max x y z (m)", source)


@dataclass
class ColliderConfig:
    type: str = spec_field("str", choices=("plane", "box"))
    point: list = spec_field("vec3", [0.0, 0.0, 0.0], lo=-1e6, hi=1e6, unit="m")
    normal: list = spec_field("vec3", [0.0, 1.0, 0.0], lo=-1.0, hi=1.0, unit="-")
    center: list = spec_field("vec3", [0.0, 0.0, 0.0], lo=-1e6, hi=1e6, unit="m")
    size: list = spec_field("vec3", [1.0, 1.0, 1.0], lo=0.0, hi=1e4, lo_open=True, unit="m")
    restitution: float = spec_field("float", 0.2, lo=0.0, hi=1.0, unit="-")
    friction: float = spec_field("float", 0.5, lo=0.0, hi=10.0, unit="-")
    young: float = spec_field("float", 3.0e10, lo=1e3, hi=1e13, unit="Pa (for the Hertz impact)")
    poisson: float = spec_field("float", 0.2, lo=-0.99, hi=0.499, unit="-")

    def check(self, path: str, source: str) -> None:
        if self.type == "plane" and math.hypot(*self.normal) < 1e-9:
            raise ConfigError(f"{path}.normal", self.normal, "a non-zero vector", source)


@dataclass
class ScriptedCrackConfig:
    """A crack applied at a given frame without an impact analysis (teaching scenes)."""

    frame: int = spec_field("int", lo=0, hi=100000)
    object: str = spec_field("str")
    point: list = spec_field("vec3", lo=-1e6, hi=1e6, unit="m, reference frame (the scene at t = 0)")
    normal: list = spec_field("vec3", lo=-1.0, hi=1.0, unit="-")
    radius: float = spec_field("float", 1.0, lo=0.0, hi=1e6, lo_open=True, unit="m")
    side: list = spec_field("floats", [], lo=-1.0, hi=1.0, unit="in-plane direction of a half-disc, [] = disc")
    r_inner: float = spec_field("float", 0.0, lo=0.0, hi=1e6, unit="m")


@dataclass
class CameraConfig:
    eye: list = spec_field("vec3", [0.8, 0.6, 0.8], lo=-1e6, hi=1e6, unit="m")
    target: list = spec_field("vec3", [0.0, 0.1, 0.0], lo=-1e6, hi=1e6, unit="m")
    fov: float = spec_field("float", 45.0, lo=1.0, hi=170.0, unit="deg")
    # follow: eye - target is the view direction; target and distance frame the bodies every frame
    # (render/framing.py). fixed: the eye and target as given.
    mode: str = spec_field("str", "follow", choices=("follow", "fixed"))


@dataclass
class SceneSection:
    name: str = spec_field("str")
    description: str = spec_field("str", "")
    effects: list = spec_field("strs", [], choices=EFFECTS)
    frames: int = spec_field("int", 120, lo=1, hi=100000)
    fps: float = spec_field("float", 60.0, lo=1.0, hi=1000.0, unit="frames/s")
    substeps: int = spec_field("int", 4, lo=1, hi=1000)
    seed: int = spec_field("int", 0, lo=0, hi=2**31 - 1)
    gravity: list = spec_field("vec3", [0.0, -9.81, 0.0], lo=-1e3, hi=1e3, unit="m/s^2")
    fracture_mode: str = spec_field("str", "auto", choices=("auto", "basic", "subdivision"))
    impact_threshold: float = spec_field("float", 0.5, lo=0.0, hi=1e3, unit="m/s relative normal speed")
    expected_fragments: list = spec_field("floats", [1.0, 1e9], length=2, lo=0.0,
                                          unit="[min, max] pieces after test_frames")
    test_frames: int = spec_field("int", 0, lo=0, hi=100000, unit="frames the test suite runs (0 = frames)")
    elastic_damping: float = spec_field("float", 0.0, lo=0.0, hi=1e6, unit="1/s (elastic effect)")
    body_capacity: int = spec_field("int", 0, lo=0, hi=2**24,
                                    unit="rigid bodies ever made, fragments included (0 = from the particles)")
    sphere_capacity: int = spec_field("int", 0, lo=0, hi=2**26,
                                      unit="boundary spheres at once, crack faces included (0 = from the particles)")
    contact_capacity: int = spec_field("int", 0, lo=0, hi=2**28,
                                       unit="rigid contacts at once (0 = 4 per boundary sphere of the capacity)")


@dataclass
class SceneConfig:
    scene: SceneSection = spec_field("table", table=SceneSection)
    materials: list = spec_field("tables", [], table=MaterialConfig)
    objects: list = spec_field("tables", [], table=ObjectConfig)
    colliders: list = spec_field("tables", [], table=ColliderConfig)
    camera: CameraConfig = spec_field("table", CameraConfig(), table=CameraConfig)
    cracks: list = spec_field("tables", [], table=ScriptedCrackConfig)
    source: str = ""

    def check(self, path: str, source: str) -> None:
        effects = self.scene.effects
        for e in effects:
            need = EFFECT_NEEDS.get(e)
            if need and need not in effects:
                raise ConfigError("scene.effects", effects, f"'{e}' needs '{need}' in the list too", source)
        if not self.objects:
            raise ConfigError("objects", [], "at least one [[objects]] table", source)
        names = [m.name for m in self.materials]
        for i, m in enumerate(self.materials):
            if m.kernel.mode == "wpca" and not self.has("wpca"):
                raise ConfigError(f"materials[{i}].kernel.mode", "wpca", "'wpca' in scene.effects too", source)
        for i, m in enumerate(names):
            if names.count(m) > 1:
                raise ConfigError(f"materials[{i}].name", m, "a unique material name", source)
        for i, o in enumerate(self.objects):
            if o.material not in names:
                raise ConfigError(f"objects[{i}].material", o.material, "a material named in [[materials]]: "
                                  + ", ".join(names), source)
            if o.count > 1 and not any(o.spacing):
                raise ConfigError(f"objects[{i}].spacing", o.spacing, "a non-zero offset between copies", source)
            for region, mat in o.region_materials.items():
                if mat not in names:
                    raise ConfigError(f"objects[{i}].region_materials.{region}", mat, "a material name", source)

        objects = [o.name for o in self.objects]
        for i, c in enumerate(self.cracks):
            if c.object not in objects:
                raise ConfigError(f"cracks[{i}].object", c.object, "an object name: " + ", ".join(objects), source)
            if not self.has("fracture"):
                raise ConfigError(f"cracks[{i}]", c.object, "scripted cracks need 'fracture' in scene.effects", source)

    def has(self, effect: str) -> bool:
        return effect in self.scene.effects

    def material(self, name: str) -> MaterialConfig:
        return next(m for m in self.materials if m.name == name)


SECTIONS = [
    ("[scene]", SceneSection),
    ("[[materials]]", MaterialConfig),
    ("kernel = { ... } (in a material)", KernelConfig),
    ("[[objects]]", ObjectConfig),
    ("[[colliders]]", ColliderConfig),
    ("[camera]", CameraConfig),
    ("[[cracks]] (scripted cracks, teaching scenes)", ScriptedCrackConfig),
]


def schema_markdown() -> str:
    """The scene schema as Markdown tables (docs/scenes.md embeds this; a test keeps them equal)."""
    lines = []
    for title, cls in SECTIONS:
        lines += [f"### {title}", "", "| key | default | allowed |", "|---|---|---|"]
        for f in fields(cls):
            if "spec" not in f.metadata:
                continue
            spec = f.metadata["spec"]
            if f.default is not MISSING:
                default = repr(f.default)
            elif f.default_factory is not MISSING:
                value = f.default_factory()
                default = "see below" if hasattr(value, "__dataclass_fields__") else repr(value)
            else:
                default = "required"
            lines.append(f"| `{f.name}` | {default} | {spec.allowed()} |")
        lines.append("")
    return "\n".join(lines)
