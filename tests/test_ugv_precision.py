"""Precision analysis of Zhao et al. §3.4 (eqs. 8-16): the paper's figures from Table 1, and Table 1 in the robots."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from marsupial.skills.ugv_docking.precision import PrecisionParams, analyse, k_h_deviation
from marsupial.world import World


def test_paper_figures_from_table_1():
    result = analyse()
    assert result.d_uf == pytest.approx(16 / 3)  # eq. (9)
    assert result.e_u == pytest.approx(0.8165, abs=1e-4)  # eq. (10): E_u ≤ 0.8165
    assert result.d_vi == pytest.approx(4 / 3)  # eq. (13)
    assert result.e_k == pytest.approx(0.0014, abs=5e-5)  # eq. (14): E_k ≈ 0.0014
    assert result.delta_x_e == pytest.approx(0.00817, abs=1e-5)  # eq. (12): |Δx_e| < 0.817 cm
    assert result.needed == pytest.approx(0.09317, abs=1e-5)  # |Δx_e| + b_c/2 < 9.317 cm
    assert result.docks


def test_entry_offset_bound_of_eq_16():
    """The paper's |Δα| < 0.96° (and b_e cos(0.96°)/2 = 9.498 cm) comes out of eq. (16) with Δk = 0.01.

    With Table 1's Δk = 0.02 the same equation gives 1.64°; eq. (8) holds either way.
    """
    paper = analyse(PrecisionParams(delta_k=0.01))
    assert math.degrees(paper.delta_alpha) == pytest.approx(0.96, abs=0.005)
    assert paper.clearance == pytest.approx(0.09498, abs=1e-5) and paper.clearance > paper.needed
    table_1 = analyse()
    assert math.degrees(table_1.delta_alpha) == pytest.approx(1.637, abs=0.005)
    assert table_1.clearance == pytest.approx(0.09496, abs=1e-5) and table_1.docks


def test_bounds_grow_with_the_tolerances_and_docking_can_fail():
    base = analyse()
    assert analyse(replace(PrecisionParams(), delta_u=10.0)).delta_x_e > base.delta_x_e
    assert analyse(replace(PrecisionParams(), delta_k=0.04)).delta_alpha > base.delta_alpha
    assert analyse(replace(PrecisionParams(), t_n=128)).e_u == pytest.approx(base.e_u / 2)
    assert k_h_deviation(4 / 3, 100) > k_h_deviation(4 / 3, 203)  # a shorter H_GS fits k_h less well
    assert not analyse(replace(PrecisionParams(), b_c=0.18)).docks  # 0.5 cm play a side < |Δx_e|
    assert not analyse(replace(PrecisionParams(), d_e=0.5, optical_deviation=math.radians(3.0))).docks


def test_table_1_defaults_are_the_robots():
    p = PrecisionParams()
    with World(scene="marsupial_yard") as world:
        mother = world.add_robot("mother_ugv")
        child = world.add_robot("child_ugv", pose=[-1.5, 0.0, 0.0])
        p_cam, R_cam = child.camera.optical_pose()
        assert p.b_e == mother.entrance_width and p.b_c == pytest.approx(child.size[1])
        assert p.theta == pytest.approx(math.asin(R_cam[2, 2]), abs=1e-6)
        assert p.h == pytest.approx(mother.benchmark_pose()[0][2] - p_cam[2], abs=1e-4)
        intrinsics = child.camera.intrinsics
        assert (p.width, p.height) == (intrinsics.width, intrinsics.height)
        assert p.fov == pytest.approx(math.radians(intrinsics.fov_v_deg))
