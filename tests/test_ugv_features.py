"""Benchmark features of Zhao et al. §3.1 on the child's camera frames: I_h, eq. (6) against k_h, Remarks 1-2, C2, C3.

Rendered frames come from a ``child_ugv`` placed at a relative pose (α, x_e, y_e)
(Fig. 2) before a ``mother_ugv`` in the ``marsupial_yard``, with the camera's
default sensing (pixel noise, exposure and white-balance errors).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from marsupial.skills.ugv_docking.criterion import (
    CriterionList,
    MatchTolerances,
    load_criterion_list,
    matched,
    within_criterion,
)
from marsupial.skills.ugv_docking.features import T_N, BenchmarkFeatures, extract_features
from marsupial.skills.ugv_docking.geometry import border_point_image, entry_angle, ground_point, theoretical_slope
from marsupial.tools.ugv_criterion import record_criterion_list
from marsupial.world import World
from marsupial.world.robots.ugv_docking import entry_geometry, place_child

THETA = math.radians(15.0)  # camera tilt θ, Table 1
H = 0.23  # H_GS above the camera h (m), Table 1
DELTA_K = MatchTolerances().delta_k


@pytest.fixture(scope="module")
def yard():
    """A mother at an arbitrary pose and a child to place before it (one world for the module)."""
    with World(scene="marsupial_yard", seed=3) as world:
        mother = world.add_robot("mother_ugv", pose=[0.4, -0.3, 0.6])
        child = world.add_robot("child_ugv", pose=[-2.0, 0.0, 0.0])
        yield mother, child


def _view(yard, alpha_deg: float, x_e: float, y_e: float):
    """Place the child, render its frame; its features, the projected I_h (px) and eq. (6) at the true pose."""
    mother, child = yard
    place_child(mother, child, math.radians(alpha_deg), x_e, y_e)
    frame = child.camera.measure()
    p_bench = frame.rotation.T @ (mother.benchmark_pose()[0] - frame.position)
    i_h = (frame.K @ (p_bench / p_bench[2]))[:2]
    alpha, x, y = entry_geometry(mother, child)
    k_bar = theoretical_slope(alpha, x, y, H, THETA, frame.K[0, 0], frame.K[1, 1])
    return extract_features(frame.rgb), i_h, k_bar, float(p_bench[2]), frame.K[0, 0]


# ------------------------------------------------------------------ the extraction on a drawn benchmark
def _drawn_benchmark(u_c: float, v_c: float, half_width: float, half_height: float, slope: float) -> np.ndarray:
    """A grey noisy 640×480 frame with a red/green checkerboard crossing at (u_c, v_c), H_GS of slope ``slope``.

    The checkerboard is a rectangle ``2 half_width × 2 half_height`` (px) turned
    so that its horizontal border has slope dv/du = ``slope``; red top-left and bottom-right.
    """
    v, u = np.mgrid[0:480, 0:640].astype(float)
    norm = math.hypot(1.0, slope)
    along = ((u - u_c) + slope * (v - v_c)) / norm  # along H_GS, rightwards
    across = (-slope * (u - u_c) + (v - v_c)) / norm  # across it, downwards
    inside = (np.abs(along) <= half_width) & (np.abs(across) <= half_height)
    red = inside & ((along < 0) == (across < 0))
    rgb = np.full((480, 640, 3), (170.0, 170.0, 165.0))
    rgb[red] = (200.0, 15.0, 15.0)
    rgb[inside & ~red] = (15.0, 170.0, 30.0)
    rgb += np.random.default_rng(1).normal(0.0, 3.0, rgb.shape)
    return np.clip(rgb, 0, 255).astype(np.uint8)


@pytest.mark.parametrize("slope", [0.0, -0.12, 0.25])
def test_features_of_a_drawn_benchmark(slope):
    rgb = _drawn_benchmark(301.3, 207.6, 60.0, 25.0, slope)
    features = extract_features(rgb)
    assert features is not None
    assert features.u_h == pytest.approx(301.3, abs=1.0) and features.v_h == pytest.approx(207.6, abs=1.0)
    assert features.k_h == pytest.approx(slope, abs=0.005)
    assert features.s_u == pytest.approx(120.0 / math.hypot(1.0, slope), abs=2)  # H_GS is 120 px long
    assert features.n_g >= T_N and features.image_width == 640


def test_nothing_captured_without_a_whole_benchmark():
    assert extract_features(np.full((480, 640, 3), 170, np.uint8)) is None
    assert extract_features(_drawn_benchmark(300.0, 200.0, 6.0, 3.0, 0.0)) is None  # blocks under 8 px: no square
    swapped = _drawn_benchmark(300.0, 200.0, 60.0, 25.0, 0.0)[..., [1, 0, 2]]  # green top-left: another pattern
    assert extract_features(swapped) is None


# ------------------------------------------------------------------ eq. (6) against the projection (eqs. 1, 3, 4)
def test_eq_6_is_the_slope_of_the_projected_border():
    rng = np.random.default_rng(0)
    for _ in range(50):
        alpha, x_e, y_e = rng.uniform(0.3, math.pi - 0.3), rng.uniform(-0.3, 0.3), rng.uniform(0.25, 2.5)
        if x_e * math.cos(alpha) + y_e * math.sin(alpha) <= 0.05:  # eq. (2): H_GS faces the camera
            continue
        a, b = (border_point_image(d, alpha, x_e, y_e, H, THETA, 407.0, 407.0, 319.5, 239.5) for d in (y_e + 0.02, y_e))
        k_bar = theoretical_slope(alpha, x_e, y_e, H, THETA, 407.0, 407.0)
        assert (a[1] - b[1]) / (a[0] - b[0]) == pytest.approx(k_bar, rel=1e-9, abs=1e-12)
        assert np.sign(k_bar) == -np.sign(round(math.cos(alpha), 12))  # Remark 1


# ------------------------------------------------------------------ rendered frames
@pytest.mark.parametrize(
    ("alpha_deg", "x_e", "y_e"), [(90, 0.0, 0.3), (90, 0.0, 2.0), (75, 0.06, 0.6), (105, -0.1, 1.2)]
)
def test_u_h_is_the_projected_crossing(yard, alpha_deg, x_e, y_e):
    features, i_h, _, _, _ = _view(yard, alpha_deg, x_e, y_e)
    assert features is not None and features.n_g >= T_N
    assert features.u_h == pytest.approx(i_h[0], abs=2.0)
    assert features.v_h == pytest.approx(i_h[1], abs=2.0)


def test_eqs_1_4_6_inverted_give_back_the_relative_pose():
    for alpha, x_e, y_e in [(1.2, 0.1, 0.5), (2.0, -0.2, 0.8), (math.pi / 2, 0.0, 0.3), (0.9, 0.3, 0.4)]:
        u, v = border_point_image(y_e, alpha, x_e, y_e, H, THETA, 407.0, 407.0, 319.5, 239.5)  # I_h images E
        x, y = ground_point(u, v, H, THETA, 407.0, 407.0, 319.5, 239.5)
        k_bar = theoretical_slope(alpha, x_e, y_e, H, THETA, 407.0, 407.0)
        assert (x, y) == pytest.approx((x_e, y_e), abs=1e-9)
        assert entry_angle(k_bar, x, y, H, THETA, 407.0, 407.0) == pytest.approx(alpha, abs=1e-9)


@pytest.mark.parametrize(
    ("alpha_deg", "x_e", "y_e"), [(60, 0.1, 0.6), (120, -0.1, 1.0), (55, 0.0, 0.45), (125, 0.05, 1.5)]
)
def test_the_relative_pose_from_one_rendered_view(yard, alpha_deg, x_e, y_e):
    """What the independent child's repositioning estimates: E within 1 cm, α within 2° (noisy frames)."""
    mother, child = yard
    place_child(mother, child, math.radians(alpha_deg), x_e, y_e)
    frame = child.camera.measure()
    f, K = extract_features(frame.rgb), frame.K
    assert f is not None
    x, y = ground_point(f.u_h, f.v_h, H, THETA, K[0, 0], K[1, 1], K[0, 2], K[1, 2])
    assert (x, y) == pytest.approx((x_e, y_e), abs=0.01)
    assert math.degrees(entry_angle(f.k_h, x, y, H, THETA, K[0, 0], K[1, 1])) == pytest.approx(alpha_deg, abs=2.0)


ALPHAS_DEG = (70, 80, 90, 100, 110)
OFFSETS = ((-0.04, 0.35), (0.05, 0.35), (-0.04, 0.8), (0.05, 0.8))  # (x_e, y_e) in m


@pytest.fixture(scope="module")
def slope_grid(yard):
    """(α°, x_e, y_e) -> (measured k_h, eq. (6)'s k̄_h) over a small grid of relative poses."""
    grid = {}
    for alpha_deg in ALPHAS_DEG:
        for x_e, y_e in OFFSETS:
            features, _, k_bar, _, _ = _view(yard, alpha_deg, x_e, y_e)
            assert features is not None, (alpha_deg, x_e, y_e)
            grid[alpha_deg, x_e, y_e] = (features.k_h, k_bar)
    return grid


def test_measured_slope_agrees_with_eq_6(slope_grid):
    errors = [k_h - k_bar for k_h, k_bar in slope_grid.values()]
    assert max(abs(e) for e in errors) < 0.01  # within half of Δk over the grid
    assert max(abs(k_bar) for _, k_bar in slope_grid.values()) > 0.2  # the grid spans real slopes


def test_slope_sign_follows_remark_1(slope_grid):
    for (alpha_deg, _, _), (k_h, _) in slope_grid.items():
        if alpha_deg < 90:
            assert k_h < -DELTA_K
        elif alpha_deg > 90:
            assert k_h > DELTA_K
        else:
            assert abs(k_h) < DELTA_K  # aligned: H_GS horizontal in the image


def test_slope_grows_with_the_offset_and_shrinks_with_distance(slope_grid):
    """Remark 2: |k_h| rises with |π/2 - α| and falls with the distance to the station."""
    for x_e, y_e in OFFSETS:
        for side in ((90, 80, 70), (90, 100, 110)):
            magnitudes = [abs(slope_grid[a, x_e, y_e][0]) for a in side]
            assert magnitudes == sorted(magnitudes) and magnitudes[0] < magnitudes[-1]
    for alpha_deg in (70, 80, 100, 110):
        for x_e in (-0.04, 0.05):
            assert abs(slope_grid[alpha_deg, x_e, 0.35][0]) > abs(slope_grid[alpha_deg, x_e, 0.8][0])


def test_s_u_grows_as_the_child_comes_closer(yard):
    """Remark 2 / §3.2: aligned, s_u increases monotonically as the distance falls; it is H_GS's imaged width."""
    lengths = []
    for y_e in (2.0, 1.4, 1.0, 0.7, 0.5, 0.35, 0.26):
        features, _, _, depth, focal = _view(yard, 90, 0.0, y_e)
        assert features is not None
        assert features.s_u == pytest.approx(0.136 * focal / depth, abs=3)  # the benchmark is 0.136 m wide
        lengths.append(features.s_u)
    assert all(a < b for a, b in zip(lengths, lengths[1:], strict=False))


def test_no_features_when_the_child_looks_away(yard):
    assert _view(yard, 90, 0.0, -0.6)[0] is None  # the benchmark behind the camera


# ------------------------------------------------------------------ C2: the criterion list (Remark 2)
def test_shipped_criterion_list_is_what_the_child_records():
    shipped = load_criterion_list("child_ugv")
    assert shipped.robot == "child_ugv" and len(shipped.entries) >= 20
    again = record_criterion_list(shipped.distance, bearings_deg=(-30.0, 0.0, 20.0), heading_offsets_deg=(0.0, 8.0))
    recorded = dict(zip(shipped.placements, shipped.entries, strict=True))
    for placement, (k_h, s_u) in zip(again.placements, again.entries, strict=True):
        key = min(recorded, key=lambda p: math.dist(p, placement))
        assert math.dist(key, placement) < 1e-4
        assert k_h == pytest.approx(recorded[key][0], abs=0.005) and s_u == pytest.approx(recorded[key][1], abs=1)


@pytest.mark.parametrize(
    ("alpha_deg", "y_e", "inside"),
    [(90, 0.8, False), (90, 0.3, True), (70, 0.7, False), (70, 0.3, True), (115, 0.3, True)],
)
def test_c2_tells_the_criterion_distance(yard, alpha_deg, y_e, inside):
    f_list = load_criterion_list()
    assert y_e < f_list.distance if inside else y_e > f_list.distance
    features, *_ = _view(yard, alpha_deg, 0.0, y_e)
    assert features is not None
    assert within_criterion(features, f_list) is inside


def test_c2_needs_both_features_of_one_entry():
    f_list = CriterionList("child_ugv", 0.4, ((0.0, 120), (0.3, 100)), ((0.0, 0.0), (0.5, 0.0)))
    base = BenchmarkFeatures(320.0, 100.0, 0.1, 110, 60, 640)
    assert not within_criterion(base, f_list)  # s_u below the aligned entry, |k_h| below the oblique one
    assert within_criterion(replace(base, s_u=120), f_list)
    assert within_criterion(replace(base, k_h=-0.3), f_list)
    assert not within_criterion(replace(base, k_h=-0.3, s_u=99), f_list)
    assert not within_criterion(None, f_list)


# ------------------------------------------------------------------ C3: eq. (7)
def test_c3_is_eq_7():
    ready = BenchmarkFeatures(u_h=322.0, v_h=12.0, k_h=-0.015, s_u=203, n_g=64, image_width=640)
    assert matched(ready)
    assert not matched(replace(ready, k_h=0.02))  # k_h ∈ (-Δk, Δk), open
    assert not matched(replace(ready, u_h=325.0))  # u_h ∈ (W/2 - Δu, W/2 + Δu), open
    assert not matched(replace(ready, u_h=314.9))
    assert not matched(replace(ready, s_u=202))  # s_u ≥ s_u^e
    assert matched(replace(ready, s_u=180), MatchTolerances(s_u_e=180))
    assert not matched(None)
