"""A run as one animated USD stage (`--export usd`), for Omniverse, Houdini and Blender.

Same content as the glTF export (sim.animation's pieces): under /World one Xform per piece with a
translate and an orient op sampled at every frame (time code = frame index, at the scene's frame
rate), a Mesh child holding the piece's surface once, and a visibility attribute that is
`invisible` before the piece is created and after it is replaced. The stage says metres per unit
1 and up axis Y. Written with usd-core (pxr) to a temporary name and renamed.
"""

from __future__ import annotations

import os
from pathlib import Path


def write_usd(recorder, path: Path) -> Path:
    """Write the recorded pieces as a USD stage (.usd/.usdc binary, .usda text) at `path`."""
    from pxr import Gf, Sdf, Usd, UsdGeom, Vt

    path = Path(path)
    tmp = path.with_name(f".{path.stem}.tmp{path.suffix}")
    stage = Usd.Stage.CreateNew(str(tmp))
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    stage.SetTimeCodesPerSecond(recorder.fps)
    stage.SetFramesPerSecond(recorder.fps)
    stage.SetStartTimeCode(0)
    stage.SetEndTimeCode(recorder.last_frame)
    root = UsdGeom.Xform.Define(stage, "/World")
    stage.SetDefaultPrim(root.GetPrim())
    for k, piece in enumerate(recorder.pieces):
        if not piece.frames:
            continue
        xf = UsdGeom.Xform.Define(stage, f"/World/piece_{k:05d}")
        xf.GetPrim().CreateAttribute("anisofrac:body", Sdf.ValueTypeNames.Int).Set(int(piece.body))
        translate = xf.AddTranslateOp(UsdGeom.XformOp.PrecisionDouble)
        orient = xf.AddOrientOp(UsdGeom.XformOp.PrecisionFloat)
        for f, x, q in zip(piece.frames, piece.translations, piece.rotations):
            translate.Set(Gf.Vec3d(*map(float, x)), Usd.TimeCode(f))
            orient.Set(Gf.Quatf(float(q[3]), float(q[0]), float(q[1]), float(q[2])), Usd.TimeCode(f))
        vis = xf.CreateVisibilityAttr()
        if piece.start > 0:
            vis.Set(UsdGeom.Tokens.invisible, Usd.TimeCode(0))
        vis.Set(UsdGeom.Tokens.inherited, Usd.TimeCode(piece.start))
        if piece.end is not None:
            vis.Set(UsdGeom.Tokens.invisible, Usd.TimeCode(piece.end))
        mesh = UsdGeom.Mesh.Define(stage, f"/World/piece_{k:05d}/mesh")
        mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(piece.verts))
        mesh.CreateFaceVertexCountsAttr(Vt.IntArray([3] * len(piece.faces)))
        mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(piece.faces.reshape(-1).astype("int32")))
        mesh.CreateExtentAttr(Vt.Vec3fArray([Gf.Vec3f(*map(float, piece.verts.min(0))),
                                             Gf.Vec3f(*map(float, piece.verts.max(0)))]))
        mesh.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
        mesh.CreateDisplayColorAttr(Vt.Vec3fArray([Gf.Vec3f(*piece.color)]))
        mesh.CreateDisplayOpacityAttr(Vt.FloatArray([piece.opacity]))
    stage.GetRootLayer().Save()
    del stage
    os.replace(tmp, path)
    return path


__all__ = ["write_usd"]
