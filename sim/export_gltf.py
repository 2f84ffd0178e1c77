"""A run as one animated binary glTF 2.0 file (`--export glb`), for DCC tools and web viewers.

Each piece (sim.animation) is one mesh stored once and one node that moves it: translation and
rotation keyframes at the frame rate (LINEAR), and a STEP scale channel that is 0 before the piece
is created and after it is replaced, 1 while it lives. glTF units are metres and +y is up, which
is what the simulation uses, so nothing is converted. Written with pygltflib, atomically.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from core.output import atomic_write_bytes

FLOAT, UINT = 5126, 5125  # glTF component types
ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963  # glTF buffer view targets


class _Blob:
    """The binary chunk with its buffer views and accessors."""

    def __init__(self, gltf) -> None:
        self.gltf, self.chunks, self.length = gltf, [], 0

    def add(self, array: np.ndarray, kind: str, component: int, target: int | None = None, bounds: bool = False) -> int:
        import pygltflib as g

        data = np.ascontiguousarray(array).tobytes()
        view = g.BufferView(buffer=0, byteOffset=self.length, byteLength=len(data), target=target)
        self.gltf.bufferViews.append(view)
        self.chunks.append(data)
        self.length += len(data)  # every array is 4-byte items, so views stay aligned
        flat = np.asarray(array).reshape(len(array), -1)
        acc = g.Accessor(bufferView=len(self.gltf.bufferViews) - 1, componentType=component, count=len(array),
                         type=kind)
        if bounds:
            acc.min = flat.min(0).astype(float).tolist()
            acc.max = flat.max(0).astype(float).tolist()
        self.gltf.accessors.append(acc)
        return len(self.gltf.accessors) - 1


def _material(gltf, cache: dict, color: tuple, opacity: float) -> int:
    import pygltflib as g

    key = (tuple(round(c, 4) for c in color), round(opacity, 4))
    if key not in cache:
        pbr = g.PbrMetallicRoughness(baseColorFactor=[*key[0], key[1]], metallicFactor=0.0, roughnessFactor=0.6)
        gltf.materials.append(g.Material(pbrMetallicRoughness=pbr, alphaMode="BLEND" if opacity < 1 else "OPAQUE",
                                         doubleSided=False))
        cache[key] = len(gltf.materials) - 1
    return cache[key]


def _channels(blob: _Blob, anim, node: int, piece, recorder) -> None:
    import pygltflib as g

    times = np.asarray(piece.frames, np.float32) / np.float32(recorder.fps)
    t_in = blob.add(times, "SCALAR", FLOAT, bounds=True)
    moves = [("translation", np.asarray(piece.translations, np.float32), "VEC3"),
             ("rotation", np.asarray(piece.rotations, np.float32), "VEC4")]
    # shown from `start` to `end`: scale 0 -> 1 at creation, 1 -> 0 when replaced (STEP holds values)
    keys = ([0.0, recorder.time(piece.start)], [0.0, 1.0]) if piece.start > 0 else ([0.0], [1.0])
    if piece.end is not None:
        keys = (keys[0] + [recorder.time(piece.end)], keys[1] + [0.0])
    s_in = blob.add(np.asarray(keys[0], np.float32), "SCALAR", FLOAT, bounds=True)
    scale = np.repeat(np.asarray(keys[1], np.float32)[:, None], 3, axis=1)
    for path, values, kind in moves:
        output = blob.add(values, kind, FLOAT)
        anim.samplers.append(g.AnimationSampler(input=t_in, output=output, interpolation="LINEAR"))
        anim.channels.append(g.AnimationChannel(sampler=len(anim.samplers) - 1,
                                                target=g.AnimationChannelTarget(node=node, path=path)))
    anim.samplers.append(g.AnimationSampler(input=s_in, output=blob.add(scale, "VEC3", FLOAT), interpolation="STEP"))
    anim.channels.append(g.AnimationChannel(sampler=len(anim.samplers) - 1,
                                            target=g.AnimationChannelTarget(node=node, path="scale")))


def write_glb(recorder, path: Path, name: str = "anisofrac") -> Path:
    """Write the recorded pieces as one .glb: meshes once, node transforms over time."""
    import pygltflib as g

    gltf = g.GLTF2(asset=g.Asset(generator="anisofrac", version="2.0"), scene=0)
    gltf.scenes.append(g.Scene(name=name, nodes=[]))
    blob, materials = _Blob(gltf), {}
    anim = g.Animation(name=f"{name} fracture", samplers=[], channels=[])
    for k, piece in enumerate(recorder.pieces):
        if not piece.frames:
            continue  # created and replaced within one frame: never shown
        position = blob.add(piece.verts, "VEC3", FLOAT, ARRAY_BUFFER, bounds=True)
        indices = blob.add(piece.faces.reshape(-1), "SCALAR", UINT, ELEMENT_ARRAY_BUFFER)
        prim = g.Primitive(attributes=g.Attributes(POSITION=position), indices=indices,
                           material=_material(gltf, materials, piece.color, piece.opacity))
        gltf.meshes.append(g.Mesh(name=f"piece_{k}", primitives=[prim]))
        shown = piece.start == 0
        gltf.nodes.append(g.Node(name=f"piece_{k}_body_{piece.body}", mesh=len(gltf.meshes) - 1,
                                 translation=[float(v) for v in piece.translations[0]],
                                 rotation=[float(v) for v in piece.rotations[0]],
                                 scale=[1.0, 1.0, 1.0] if shown else [0.0, 0.0, 0.0]))
        node = len(gltf.nodes) - 1
        gltf.scenes[0].nodes.append(node)
        _channels(blob, anim, node, piece, recorder)
    if anim.channels:
        gltf.animations.append(anim)
    gltf.buffers.append(g.Buffer(byteLength=blob.length))
    gltf.set_binary_blob(b"".join(blob.chunks))
    atomic_write_bytes(Path(path), b"".join(gltf.save_to_bytes()))
    return Path(path)


__all__ = ["write_glb"]
