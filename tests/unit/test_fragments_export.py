"""OBJ / PLY export of fragment surfaces: exact round trip, watertight, atomic writes."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from core.errors import ConfigError
from geometry.cutting import Crack
from geometry.export import write_fragments, write_mesh
from geometry.fragments import apply_cracks, fragment_volumes
from geometry.surface import fragment_surfaces
from tests.unit.test_cut_meshes import kuhn_box, particles


@pytest.fixture(scope="module")
def cut_box():
    ps = particles(kuhn_box(3, 3, 3, jitter=0.15, seed=4))
    crack = Crack(point=[0.5, 0.5, 0.5], normal=[0.2, 0.1, 1.0], r_outer=2.0)
    out, rep = apply_cracks(ps, [crack], mode="subdivision")
    assert rep.n_fragments == 2
    return out, rep.labels, fragment_surfaces(out, rep.labels)


@pytest.mark.parametrize("fmt", ["obj", "ply"])
def test_round_trip_is_exact_and_watertight(tmp_path, cut_box, fmt):
    ps, labels, surf = cut_box
    paths = write_fragments(tmp_path, surf, fmt=fmt)
    assert [p.name for p in paths] == [f"fragment_0000.{fmt}", f"fragment_0001.{fmt}"]
    vols = fragment_volumes(ps, labels)
    for label, path in enumerate(paths):
        v, f = surf.fragment(label)
        m = trimesh.load(path, process=False)
        assert np.array_equal(np.asarray(m.vertices), v)
        assert np.array_equal(np.asarray(m.faces), f)
        assert m.is_watertight and m.is_winding_consistent
        assert abs(m.volume - vols[label]) <= 1e-9 * vols[label]
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(p.name for p in paths)  # no temp files


def test_bad_format_and_indices(tmp_path):
    with pytest.raises(ConfigError, match="format"):
        write_mesh(tmp_path / "a.stl", np.zeros((3, 3)), np.array([[0, 1, 2]]))
    with pytest.raises(ConfigError, match="faces"):
        write_mesh(tmp_path / "a.obj", np.zeros((3, 3)), np.array([[0, 1, 3]]))
    assert list(tmp_path.iterdir()) == []
