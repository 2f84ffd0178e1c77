"""Command line of the fracture sandbox (DESIGN.md section 7): thin: parse, build, hand over.

    python main.py                      run the default scene headless (see `run`)
    python main.py check OBJECT|MESH    validate and print particle/tet statistics (Table 1)
"""

from __future__ import annotations

import argparse
import json
import sys

from sim.errors import SandboxError

DEFAULT_OBJECT = "pot"


def _cmd_check(args: argparse.Namespace) -> int:
    from geometry.build import build_object

    geo = build_object(
        args.object,
        resolution=args.resolution,
        density=args.density,
        units=args.units,
        repair=args.repair,
        seed=args.seed,
        group_size=args.group_size,
    )
    r = geo.report
    if args.json:
        print(json.dumps(r, indent=2))
        return 0
    print(f"object: {args.object}")
    for line in r.get("repairs", []):
        print(f"  repaired: {line}")
    print("Table 1 (paper) counts")
    print(f"  physical particles   {r['physical_particles']:>10,}")
    print(f"  surface particles    {r['surface_particles']:>10,}")
    print(f"  boundary particles   {r['boundary_particles']:>10,}   (group size n = {r['boundary_group_size']})")
    print(f"  links                {r['links']:>10,}")
    print("tet quality")
    print(f"  tets / vertices      {r['tets']:>10,} / {r['vertices']:,}")
    print(f"  volume               {r['volume_m3']:.6g} m^3   mass {r['mass_kg']:.6g} kg")
    print(f"  tet volume min/max   {r['min_tet_volume_m3']:.3g} / {r['max_tet_volume_m3']:.3g} m^3")
    print(f"  radius ratio worst   {r['worst_radius_ratio']:.3f} (mean {r['mean_radius_ratio']:.3f}; 1 = regular)")
    print(f"  dihedral min/max     {r['min_dihedral_deg']:.1f} / {r['max_dihedral_deg']:.1f} deg")
    if "slivers_removed" in r:
        print(f"  surface slivers removed {r['slivers_removed']}")
    print(f"  thickness B          {r['thickness_m']:.4g} m")
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="main.py", description="Brittle fracture sandbox (Li, Wang & Qin 2015)")
    sub = p.add_subparsers(dest="command")
    c = sub.add_parser("check", help="validate an object or mesh and print particle/tet statistics")
    c.add_argument("object", nargs="?", default=DEFAULT_OBJECT, help="named shape or mesh file (default: pot)")
    c.add_argument("--resolution", type=float, default=None, help="target tet size in m")
    c.add_argument("--units", default=None, help="length unit of a mesh file: m, cm, mm, in, ...")
    c.add_argument("--density", type=float, default=2400.0, help="kg/m^3 (default 2400)")
    c.add_argument("--repair", action="store_true", help="repair fixable mesh problems and report them")
    c.add_argument("--seed", type=int, default=0)
    c.add_argument("--group-size", type=int, default=4, help="surface particles per boundary particle")
    c.add_argument("--json", action="store_true", help="print the report as JSON")
    c.set_defaults(func=_cmd_check)
    return p


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        args = parser.parse_args(["check", DEFAULT_OBJECT])
    try:
        return args.func(args)
    except SandboxError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
