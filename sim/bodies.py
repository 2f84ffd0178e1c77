"""Host-side facts about the World's rigid bodies that the physics packages do not keep: which scene
object a body came from, whether it may break, its thickness B for Eq. 11 and its crack history."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass
class BodyInfo:
    """Host-side facts about a simulated body (index = rigid body id)."""

    object_index: int  # index into scene.objects
    breakable: bool
    static: bool
    thickness: float  # m: the object's thickness B (Eq. 11)
    resolution: float  # m: tet size the object was built at
    history: list = field(default_factory=list)  # cracks already applied (reference frame)
    bounds: tuple = ()  # (lo, hi) m: rest bounding box of the object the body came from
