"""Plain records of the rigid world: its parameters (RigidConfig), a host copy of every body's pose and
velocity (BodyState), and the contacts of the last step (ContactEvents). SI units throughout."""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from core.arrays import unique_rows
from core.errors import ConfigError


@dataclass
class RigidConfig:
    """Solver parameters (SI units). Defaults suit objects of 1 cm to 1 m at dt = 1/240 s."""

    gravity: tuple = (0.0, -9.81, 0.0)  # m/s^2
    substeps: int = 8  # -: solver substeps per step (contacts are found once per step)
    velocity_iterations: int = 4  # -: sequential-impulse passes per substep (even: symmetric sweeps)
    restitution_iterations: int = 2  # -: restitution passes per step
    position_iterations: int = 4  # -: split-impulse passes per step (even: symmetric sweeps)
    restitution_threshold_mps: float = 0.5  # m/s: closing speeds below this never bounce
    linear_slop_m: float = 2.0e-5  # m: penetration left uncorrected (keeps resting contacts warm)
    position_correction_rate: float = 0.2  # -: fraction of the penetration removed per step
    max_correction_speed_mps: float = 1.0  # m/s: cap of the pseudo velocity of the position correction
    speculative_margin_m: float = 2.0e-3  # m: contacts are created this far before touching
    linear_damping_per_s: float = 0.0  # 1/s: v <- v / (1 + c dt)
    angular_damping_per_s: float = 0.0  # 1/s: w <- w / (1 + c dt)
    max_speed_mps: float = 200.0  # m/s: linear speed clamp
    # -: a step is split so that no dynamic body moves more than this many of its own bounding radii
    # per split (found contacts hold a body only so far: a 2 cm ball at 200 m/s passed a thin pane); 0 = off
    max_travel_per_step: float = 8.0
    max_rotation_per_step_rad: float = 0.25 * math.pi  # rad: |w| dt clamp
    mass_ratio_cap: float = 4.0  # -: heavy-on-light contacts are solved as if at most this ratio (0 = off)
    max_support_levels: int = 64  # -: stack depth up to which support levels are computed
    warm_start: bool = True  # reuse last step's impulses of contacts matched by (sphere, sphere) key
    warm_start_factor: float = 1.0  # -: fraction of the previous impulse reused
    # m: a contact penetrating deeper than this starts from zero impulse: a deep overlap (pieces of a split
    # whose spheres interlock across the crack) is being pushed apart by the position correction, and the
    # impulses of its opposing contacts, which cancel, grew step after step when carried over (an unbounded
    # drift that ended in a 200 m/s shard); resting contacts sink a few slops at most
    warm_start_max_depth_m: float = 1.0e-3
    sleep_enabled: bool = True
    sleep_linear_speed_mps: float = 0.05  # m/s: below this (and the angular one) a body may sleep
    sleep_angular_speed_radps: float = 0.1  # rad/s
    time_to_sleep_s: float = 0.5  # s: an island sleeps after every body was slow this long

    _RANGES = {
        "substeps": (1, 64),
        "velocity_iterations": (1, 1000),
        "restitution_iterations": (0, 100),
        "position_iterations": (0, 1000),
        "restitution_threshold_mps": (0.0, 1e3),
        "linear_slop_m": (0.0, 1.0),
        "position_correction_rate": (0.0, 1.0),
        "max_correction_speed_mps": (0.0, 1e3),
        "speculative_margin_m": (0.0, 10.0),
        "linear_damping_per_s": (0.0, 1e6),
        "angular_damping_per_s": (0.0, 1e6),
        "max_speed_mps": (1e-6, 1e6),
        "max_travel_per_step": (0.0, 1e6),
        "max_rotation_per_step_rad": (1e-6, math.pi),
        "warm_start_factor": (0.0, 1.0),
        "warm_start_max_depth_m": (0.0, 10.0),
        "max_support_levels": (0, 100000),
        "mass_ratio_cap": (0.0, 1e12),
        "sleep_linear_speed_mps": (0.0, 1e3),
        "sleep_angular_speed_radps": (0.0, 1e3),
        "time_to_sleep_s": (0.0, 1e6),
    }

    def validate(self) -> None:
        """Raise ConfigError naming the key, its value and the allowed range."""
        g = tuple(self.gravity)
        if len(g) != 3 or not all(math.isfinite(float(c)) for c in g):
            raise ConfigError("rigid.gravity", self.gravity, "three finite numbers (m/s^2)")
        for f in fields(self):
            if f.name in self._RANGES:
                lo, hi = self._RANGES[f.name]
                val = getattr(self, f.name)
                if not (isinstance(val, (int, float)) and math.isfinite(val) and lo <= val <= hi):
                    raise ConfigError(f"rigid.{f.name}", val, f"[{lo}, {hi}]")


@dataclass
class BodyState:
    """Pose and velocity of all bodies (index = body id), numpy copies."""

    x: np.ndarray  # (NB, 3) m: COM world position
    q: np.ndarray  # (NB, 4) -: w-x-y-z
    v: np.ndarray  # (NB, 3) m/s
    w: np.ndarray  # (NB, 3) rad/s, world frame
    asleep: np.ndarray  # (NB,) bool
    alive: np.ndarray  # (NB,) bool
    sleep_time: np.ndarray | None = None  # (NB,) s: time spent below the sleep speeds

    def copy(self) -> BodyState:
        return BodyState(*(None if a is None else a.copy() for a in (self.x, self.q, self.v, self.w, self.asleep,
                                                                       self.alive, self.sleep_time)))


@dataclass
class ContactEvents:
    """Contacts of the last step, one row per (sphere, sphere) or (sphere, collider) contact.

    body_b is -1 for a static collider (then `collider` names it; otherwise collider = -1). The
    normal points from B towards A; `normal_impulse` (N s) is the total impulse the step applied
    (velocity and restitution passes, not the position correction); `normal_speed` (m/s) is the
    relative normal velocity of A with respect to B before the solve (negative = closing).
    """

    body_a: np.ndarray  # (C,) int
    body_b: np.ndarray  # (C,) int
    sphere_a: np.ndarray  # (C,) int
    sphere_b: np.ndarray  # (C,) int: -1 for a collider
    collider: np.ndarray  # (C,) int: -1 for a sphere-sphere contact
    point: np.ndarray  # (C, 3) m
    normal: np.ndarray  # (C, 3) -
    normal_impulse: np.ndarray  # (C,) N s
    normal_speed: np.ndarray  # (C,) m/s
    separation: np.ndarray  # (C,) m: gap at the step start (negative = penetration)
    site_radius: np.ndarray  # (C,) m: the larger radius of the contact's spheres (sphere A's on a collider)

    def __len__(self) -> int:
        return len(self.body_a)

    def touching(self) -> ContactEvents:
        """Only the contacts that carried impulse."""
        return self._select(self.normal_impulse > 0.0)

    def _select(self, mask: np.ndarray) -> ContactEvents:
        return ContactEvents(**{f.name: getattr(self, f.name)[mask] for f in fields(self)})

    def by_body_pair(self, site_above: float = -math.inf) -> dict:
        """Impacts summed per body pair: arrays body_a, body_b, impulse (N s, summed), speed (m/s, most
        negative pre-solve normal speed), point (impulse-weighted mean), normal (impulse-weighted,
        normalised), and site_point, site_normal: the same means over the pair's hardest site, the contact
        with the largest impulse and those whose spheres overlap its sphere (NaN for the pairs closing at
        `site_above` m/s or slower: only the impacts a caller keeps need them). The mean point can lie off
        both bodies where they touch on a ring (a pot landing on its rim: the ring's centre is in the
        opening) or on separate patches (a body on two feet); the site's always lies where they touch.
        Only contacts with impulse > 0 count."""
        ev = self.touching()
        if len(ev) == 0:
            z = np.zeros(0)
            return dict(body_a=z.astype(int), body_b=z.astype(int), impulse=z, speed=z, point=np.zeros((0, 3)),
                        normal=np.zeros((0, 3)), site_point=np.zeros((0, 3)), site_normal=np.zeros((0, 3)))
        pairs = np.stack([ev.body_a, ev.body_b], 1)
        uniq, inv = unique_rows(pairs, return_inverse=True)
        m = len(uniq)
        speed = np.full(m, np.inf)
        np.minimum.at(speed, inv, ev.normal_speed)
        imp, pt, nr = _weighted_means(inv, m, ev.normal_impulse, ev.point, ev.normal)
        site_pt, site_nr = np.full((m, 3), np.nan), np.full((m, 3), np.nan)
        fast = -speed > site_above
        wanted = np.flatnonzero(fast)  # the pairs whose sites are made, ascending
        if len(wanted):
            rows = np.flatnonzero(fast[inv])
            site_pt[wanted], site_nr[wanted] = ev._hardest_sites(rows, np.searchsorted(wanted, inv[rows]), len(wanted))
        return dict(body_a=uniq[:, 0], body_b=uniq[:, 1], impulse=imp, speed=speed, point=pt, normal=nr,
                    site_point=site_pt, site_normal=site_nr)

    def _hardest_sites(self, rows: np.ndarray, group: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
        """(points (n,3), unit normals (n,3)) of the hardest site of each group 0..n-1 (none empty) of the
        contacts `rows`: the impulse-weighted means over its hardest contact and those whose spheres overlap
        that one's sphere."""
        order = np.lexsort((-self.normal_impulse[rows], group))  # each group's contacts, the largest impulse first
        first = order[np.r_[0, np.flatnonzero(np.diff(group[order])) + 1]]  # (n,): each group's hardest
        hardest = rows[first][group]  # (R,): the hardest contact of each row's group
        p = self.point[rows]
        in_site = np.linalg.norm(p - self.point[hardest], axis=1) <= self.site_radius[rows] + self.site_radius[hardest]
        _, site_pt, site_nr = _weighted_means(group, n, self.normal_impulse[rows] * in_site, p, self.normal[rows])
        return site_pt, site_nr


def _weighted_means(inv: np.ndarray, m: int, weight: np.ndarray, point: np.ndarray, normal: np.ndarray):
    """Per group of `inv` (m groups): (summed weight, weighted mean point, weighted mean normal normalised)."""
    total = np.bincount(inv, weights=weight, minlength=m)
    pt = np.stack([np.bincount(inv, weights=weight * point[:, k], minlength=m) for k in range(3)], 1)
    nr = np.stack([np.bincount(inv, weights=weight * normal[:, k], minlength=m) for k in range(3)], 1)
    nr /= np.maximum(np.linalg.norm(nr, axis=1, keepdims=True), 1e-300)
    return total, pt / total[:, None], nr
