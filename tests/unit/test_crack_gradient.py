"""SPH gradient (Eq. 7) of the contact fields at tet particles against the analytic gradient:
the error shrinks with resolution for plain SPH, Bonet-Lok and the quadratic fit; the operator is
the one sph/corotated.py uses (orders 0 and 1)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from geometry.build import build_object
from sph.contact import boussinesq_displacement, boussinesq_gradient, plate_displacement, plate_gradient
from sph.cracks import neighbour_pairs, sph_gradient
from sph.kernel import kernel_isotropic

E, NU = 7.0e10, 0.22
R_REGION = 0.03  # m: fixed region around the load where the error is measured
ELL = 0.01  # m: fixed regularisation length (the same field at every resolution)
H_FACTOR = 2.0  # kernel support radius / tet resolution


def _errors(kind: str, res: float) -> tuple[int, list[float]]:
    """Volume-weighted relative L2 error of grad u over the region, for orders 0, 1, 2."""
    if kind == "block":
        obj = build_object("box", shape_params=dict(size=[0.12, 0.12, 0.06]), resolution=res)
        top = 0.03
    else:
        obj = build_object("pane", shape_params=dict(size=[0.16, 0.16, 0.008]), resolution=res)
        top = 0.004
    ps = obj.particles
    x, V = ps.centroid, ps.volume
    P = np.array([0.0013, 0.0007, top])
    n = np.array([0.0, 0.0, -1.0])  # inward normal of the top face
    frame = np.stack([[1.0, 0.0, 0.0], np.cross(n, [1.0, 0.0, 0.0]), n])
    loc = (x - P) @ frame.T
    G = np.broadcast_to(kernel_isotropic(H_FACTOR * res), (len(x), 3, 3))
    d = np.linalg.norm(x - P, axis=1)
    mem = np.flatnonzero(d < R_REGION)
    own, nbr = neighbour_pairs(x, G, mem, np.flatnonzero(d < R_REGION + H_FACTOR * res))
    if kind == "block":
        u = boussinesq_displacement(loc, 1.0, E, NU, ELL) @ frame
        ga = boussinesq_gradient(loc[mem], 1.0, E, NU, ELL)
    else:
        u = plate_displacement(loc, 1.0, E, NU, 0.008, 0.3, ELL) @ frame
        ga = plate_gradient(loc[mem], 1.0, E, NU, 0.008, 0.3, ELL)
    ga = np.einsum("ai,nab,bj->nij", frame, ga, frame)
    errs = []
    for order in (0, 1, 2):
        g, used = sph_gradient(x, V, G, u, mem, own, nbr, order)
        assert np.all(used == order)  # no fallback in these neighbourhoods
        num = (V[mem] * ((g - ga) ** 2).sum(axis=(1, 2))).sum()
        den = (V[mem] * (ga**2).sum(axis=(1, 2))).sum()
        errs.append(math.sqrt(num / den))
    return len(x), errs


def _report(kind: str, rows: list) -> None:
    print(f"\n[SPH gradient of the {kind} field, h = {H_FACTOR} x resolution, region r < {R_REGION} m]")
    for res, n, e in rows:
        print(f"  res {res * 1e3:5.1f} mm  {n:6d} particles  rel. L2 error: plain {e[0]:.4f}  "
              f"Bonet-Lok {e[1]:.4f}  quadratic {e[2]:.4f}")


def _check_convergence(rows: list, shrink: tuple[float, float, float]) -> None:
    first, last = rows[0][2], rows[-1][2]
    for order in range(3):
        assert last[order] < shrink[order] * first[order], f"order {order}: {first[order]:.4f} -> {last[order]:.4f}"
    assert last[2] < last[1] < last[0]  # each correction order helps


def test_plate_field_gradient_converges(capsys):
    rows = []
    for res in (0.012, 0.008, 0.0056):
        n, e = _errors("pane", res)
        rows.append((res, n, e))
    with capsys.disabled():
        _report("plate (pane 0.16 x 0.16 x 0.008 m)", rows)
    _check_convergence(rows, (0.8, 0.4, 0.4))
    assert rows[-1][2][2] < 0.01


def test_boussinesq_field_gradient_converges(capsys):
    rows = []
    for res in (0.012, 0.008):
        n, e = _errors("block", res)
        rows.append((res, n, e))
    with capsys.disabled():
        _report("Boussinesq (block 0.12 x 0.12 x 0.06 m)", rows)
    _check_convergence(rows, (0.85, 0.75, 0.7))
    assert rows[-1][2][2] < 0.2


@pytest.mark.slow
def test_boussinesq_field_gradient_converges_finer(capsys):
    rows = []
    for res in (0.012, 0.008, 0.0056):
        n, e = _errors("block", res)
        rows.append((res, n, e))
    with capsys.disabled():
        _report("Boussinesq (block, three resolutions)", rows)
    _check_convergence(rows, (0.7, 0.5, 0.4))


def test_gradient_operator_is_the_corotated_one():
    """Orders 0 and 1 give the same d_ij as sph.corotated.rest_operators on the same pairs."""
    from sph.corotated import rest_operators

    obj = build_object("box", shape_params=dict(size=[0.06, 0.06, 0.03]), resolution=0.01)
    x, V = obj.particles.centroid, obj.particles.volume
    G = np.broadcast_to(kernel_isotropic(0.02), (len(x), 3, 3)).copy()
    mem = np.arange(len(x))
    own, nbr = neighbour_pairs(x, G, mem, mem)
    off = np.concatenate([[0], np.cumsum(np.bincount(own, minlength=len(x)))])
    rng = np.random.default_rng(0)
    u = rng.normal(size=(len(x), 3))
    for order in (0, 1):
        rest = rest_operators(x, V, G, off, nbr, order)
        ref = np.zeros((len(x), 3, 3))
        np.add.at(ref, own, (u[nbr] - u[own])[:, :, None] * rest["d"][:, None, :])
        g, _ = sph_gradient(x, V, G, u, mem, own, nbr, order)
        assert np.allclose(g, ref, rtol=1e-10, atol=1e-10 * np.abs(ref).max())


def test_linear_field_is_exact_with_correction():
    """Patch test: orders 1 and 2 reproduce a linear field's gradient at every particle (surface too)."""
    obj = build_object("box", shape_params=dict(size=[0.06, 0.06, 0.03]), resolution=0.01)
    x, V = obj.particles.centroid, obj.particles.volume
    G = np.broadcast_to(kernel_isotropic(0.02), (len(x), 3, 3))
    mem = np.arange(len(x))
    own, nbr = neighbour_pairs(x, G, mem, mem)
    A = np.array([[1.0, -2.0, 0.5], [0.3, 0.7, -1.1], [2.0, 0.1, -0.4]]) * 1e-3
    for order in (1, 2):
        g, used = sph_gradient(x, V, G, x @ A.T, mem, own, nbr, order)
        ok = used == order
        assert ok.mean() > 0.9
        assert np.abs(g[ok] - A).max() < 1e-9 * np.abs(A).max()


def test_blocks_of_members_give_the_same_bits(monkeypatch):
    """sph_gradient pads members in blocks (PAD_SLOTS); any block size gives the same gradient, bit
    for bit (every block is padded to the same width, so each member's sums are the same arithmetic)."""
    import sph.gradient as gradient

    monkeypatch.setattr(gradient, "kernels_run", lambda: False)  # the numpy path, where blocks exist
    obj = build_object("box", shape_params=dict(size=[0.06, 0.06, 0.03]), resolution=0.006)
    x, V = obj.particles.centroid, obj.particles.volume
    G = np.broadcast_to(kernel_isotropic(2.5 * 0.006), (len(x), 3, 3))
    u = np.sin(40.0 * x) * 1e-6  # m: a smooth non-linear displacement
    mem = np.arange(0, len(x), 2)
    own, nbr = neighbour_pairs(x, G, mem, np.arange(len(x)))
    out = []
    for slots in (1, 1000, 1 << 30):  # one member per block, a few, all at once
        monkeypatch.setattr(gradient, "PAD_SLOTS", slots)
        out.append([sph_gradient(x, V, G, u, mem, own, nbr, order) for order in (0, 1, 2)])
    for other in out[1:]:
        for (g0, u0), (g1, u1) in zip(out[0], other):
            assert np.array_equal(g0, g1) and np.array_equal(u0, u1)


def test_kernels_give_the_numpy_sums(monkeypatch):
    """The Taichi kernels (sph/gradient_kernels.py) find the numpy path's pairs exactly and its gradients
    to float64 rounding, in every branch: quadratic fits, Bonet-Lok and plain weights where a member has
    too few neighbours for a fit or a singular moment, stretched kernels of two sizes."""
    import sph.gradient as gradient

    assert gradient.kernels_run()  # the suite runs on a started CPU runtime
    obj = build_object("box", shape_params=dict(size=[0.06, 0.06, 0.03]), resolution=0.005)
    x, V = obj.particles.centroid, obj.particles.volume
    scale = np.where(np.arange(len(x)) % 3 == 0, 1.3, 1.0)[:, None, None]  # mixed support radii
    G = kernel_isotropic(2.5 * 0.005) * np.diag([1.0, 0.5, 1.0]) / scale
    u = np.sin(40.0 * x) * 1e-6  # m: a smooth non-linear displacement
    mem = np.arange(0, len(x), 2)
    # neighbours dense where x < 0 (fits), every 9th up to 0.015 m (too few for a fit: Bonet-Lok), every
    # 61st beyond (one or two: a singular B, plain weights)
    k = np.arange(len(x))
    local = np.flatnonzero((x[:, 0] < 0.0) | ((x[:, 0] < 0.015) & (k % 9 == 0)) | (k % 61 == 0))

    def both(fn, *args):
        with monkeypatch.context() as m:
            m.setattr(gradient, "kernels_run", lambda: False)
            ref = fn(*args)
        return fn(*args), ref

    pairs, pairs_ref = both(gradient.neighbour_pairs, x, G, mem, local)
    assert all(np.array_equal(a, b) and a.dtype == b.dtype for a, b in zip(pairs, pairs_ref))
    monkeypatch.setattr(gradient, "PAIR_CELLS", 7 * local.size)  # members in chunks of 7: the same pairs
    assert all(np.array_equal(a, b) for a, b in zip(gradient.neighbour_pairs(x, G, mem, local), pairs))
    seen = set()
    for order in (0, 1, 2):
        (g, used), (g_ref, used_ref) = both(gradient.sph_gradient, x, V, G, u, mem, *pairs, order)
        assert np.array_equal(used, used_ref)
        seen |= {(order, int(kind)) for kind in np.unique(used)}
        scale_m = np.abs(g_ref).max(axis=(1, 2), keepdims=True)  # each member's own magnitude
        assert np.all(np.abs(g - g_ref) <= 1e-9 * scale_m)
    assert {(0, 0), (1, 0), (1, 1), (2, 1), (2, 2)} <= seen  # every branch ran


_THREADS_CHILD = """
import sys
import numpy as np
sys.path.insert(0, sys.argv[1])
from core.runtime import init_taichi
init_taichi(arch="cpu", precision="f64", threads=2)
from tests.unit.test_crack_gradient import _kernel_case
np.savez(sys.argv[2], **_kernel_case())
"""


def _kernel_case() -> dict:
    """Pairs and gradients (orders 0-2) of a stretched-kernel box by whatever path the runtime takes."""
    import sph.gradient as gradient

    obj = build_object("box", shape_params=dict(size=[0.05, 0.05, 0.03]), resolution=0.005)
    x, V = obj.particles.centroid, obj.particles.volume
    G = kernel_isotropic(2.5 * 0.005) * np.diag([1.0, 0.6, 1.0])
    G = np.broadcast_to(G, (len(x), 3, 3)).copy()
    u = np.sin(40.0 * x) * 1e-6  # m
    mem = np.arange(0, len(x), 2)
    owner, nbr = gradient.neighbour_pairs(x, G, mem, np.arange(len(x)))
    out = dict(owner=owner, nbr=nbr)
    for order in (0, 1, 2):
        out[f"grad{order}"], out[f"used{order}"] = gradient.sph_gradient(x, V, G, u, mem, owner, nbr, order)
    return out


def test_kernels_give_the_same_bits_on_two_threads(tmp_path):
    """With `--threads 2` the kernels' member loops run on Taichi's pool: each member's sums stay in one
    thread in pair order, so a two-thread process gives this one-thread process's pairs and gradients
    bit for bit (the README says results of the analysis do not depend on the thread count)."""
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    out = tmp_path / "two_threads.npz"
    subprocess.run([sys.executable, "-c", _THREADS_CHILD, str(root), str(out)], check=True, cwd=root, timeout=300,
                   capture_output=True)
    mine, theirs = _kernel_case(), np.load(out)
    assert set(mine) == set(theirs.files)
    for key, value in mine.items():
        assert np.array_equal(value, theirs[key]), key
