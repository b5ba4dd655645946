"""A tight aperture for the insertion trials (``world.disturbances.aperture_fit``): the clearance it asks for.

The opening must be the shape's outline scaled so that the MAV's outline C_m fits with the drawn clearance
(checked on the truth geometry: the outline grown by a little less than c fits at the pose found, and for the
rectangle the scale is the analytic one), be built as a wall that rays and contacts see exactly, close the other
openings, follow the seed, and refuse bad entries with an error naming the key (exit code 2 from the CLI).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pybullet
import pytest
from click.testing import CliRunner
from shapely import affinity
from shapely.geometry import Polygon

from marsupial.api.config import ApertureFitEntry
from marsupial.api.errors import UnknownNameError
from marsupial.api.silhouette import mav_silhouette
from marsupial.trees.cli import cli
from marsupial.trees.errors import MissionError
from marsupial.trees.mission import parse_mission
from marsupial.world import World
from marsupial.world.aperture_fit import draw_fit
from marsupial.world.apertures import aperture_outline
from marsupial.world.disturbances import apply_disturbances

MISSION = Path(__file__).resolve().parents[1] / "benchmarks" / "missions" / "aperture_insertion.yaml"
TOLERANCE_M = 2e-4  # the bisection's and the angle search's precision, with room


def _mav() -> Polygon:
    """C_m in metres in the wall plane (x right, z up), about the centre of mass."""
    outline = mav_silhouette()
    return Polygon(np.c_[outline[:, 0], -outline[:, 1]])


def _passes(world: World, x: float, z: float) -> bool:
    """Whether a ray along +y through the wall plane at (x, z) meets nothing between y = −0.2 and 0.2 m."""
    return pybullet.rayTest([x, -0.2, z], [x, 0.2, z], physicsClientId=world.client_id)[0][0] < 0


@pytest.mark.slow
def test_the_opening_gives_the_mav_the_clearance_asked_for_and_the_wall_is_built_so():
    clearance = 0.02
    with World(scene="collapsed_mockup", seed=0) as world:
        made = apply_disturbances(world, {"aperture_fit": {"shape": "collapsed", "clearance": clearance}}).aperture_fit
        assert made is not None and made.shape == "collapsed"
        assert abs(made.fit.clearance - clearance) <= TOLERANCE_M
        placed = affinity.translate(affinity.rotate(_mav(), made.fit.angle, origin=(0, 0), use_radians=True),
                                    *made.fit.centre)
        assert made.opening.contains(placed.buffer(clearance - TOLERANCE_M))  # the truth outline, no search
        assert not made.opening.contains(placed.buffer(clearance + TOLERANCE_M))
        expected = affinity.scale(aperture_outline("collapsed"), made.scale, made.scale, origin=(-0.3, 0.9))
        assert made.opening.symmetric_difference(expected).area < 1e-12
        # the built wall: open where the MAV goes, closed just outside the opening and at the other apertures
        assert _passes(world, *made.fit.centre)
        x0, z0, x1, z1 = made.opening.bounds
        assert not _passes(world, x0 - 0.002, (z0 + z1) / 2) and not _passes(world, (x0 + x1) / 2, z1 + 0.002)
        for shape in ("orthogonal", "amoeba", "u"):
            assert not _passes(world, *aperture_outline(shape).representative_point().coords[0])
        scene = world.scene
        assert [z.label for z in scene.zones_tagged("aperture")] == ["aperture_collapsed"]
        assert np.allclose(scene.zone("aperture_collapsed").lo[::2], (x0, z0))
        assert all(o.label.startswith("aperture_fit_") for o in scene.tagged("mockup_wall"))


def test_the_rectangle_is_scaled_by_the_analytic_factor():
    """At 3 cm the MAV lies level in the orthogonal opening: k · 0.16 m = the outline's height + 2 c."""
    clearance = 0.03
    with World(scene="collapsed_mockup", seed=0) as world:
        made = apply_disturbances(world, {"aperture_fit": {"shape": "orthogonal", "clearance": clearance}}).aperture_fit
    assert made is not None
    _, z0, _, z1 = _mav().bounds
    assert made.scale * 0.16 == pytest.approx(z1 - z0 + 2 * clearance, rel=2e-3)


def test_the_shape_and_the_clearance_follow_the_seed():
    entry = ApertureFitEntry(shape=["orthogonal", "collapsed", "amoeba", "u"], clearance=[0.01, 0.03])
    draws = []
    for seed in (3, 3, 4):
        with World(scene=None, seed=seed) as world:
            draws.append(draw_fit(entry, world.rng_for("disturbance/aperture_fit")))
    assert draws[0] == draws[1] != draws[2]
    assert all(0.01 <= c <= 0.03 for _, c in draws)


@pytest.mark.parametrize(("entry", "message"), [
    ("{shape: amoeba, clearance: [0.03, 0.01]}",
     "m.yaml:4:48: world.disturbances.aperture_fit.clearance: [low, high] = [0.03, 0.01] is decreasing; "
     "expected [low, high] with low <= high"),
    ("{shape: amoeba, clearance: 0}", "aperture_fit.clearance: invalid value 0; expected a value > 0"),
    ("{shape: amoeba, clearance: 2 cm}", "aperture_fit.clearance: invalid value '2 cm'; expected a number or a list"),
    ("{shape: amoeba, clearance: 0.5}", "aperture_fit.clearance: invalid value 0.5; expected a value <= 0.1"),
    ("{shape: [], clearance: 0.02}", "aperture_fit.shape: invalid value []; expected at least 1 item(s)"),
    ("{shape: amoeba}", "m.yaml:4:18: world.disturbances.aperture_fit.clearance: missing required key 'clearance'"),
    ("{shape: amoeba, clearance: 0.02, size: 1}", "aperture_fit.size: unknown key 'size'; expected one of clearance, "
     "shape"),
])
def test_bad_entries_are_refused_at_their_line(entry, message):
    with pytest.raises(MissionError) as caught:
        parse_mission(f"mission: m\nworld:\n  scene: collapsed_mockup\n  disturbances: {{aperture_fit: {entry}}}\n"
                      "tree: {idle: true}\n", "m.yaml")
    assert message in str(caught.value)


def test_an_unknown_shape_lists_the_scenes_apertures():
    with World(scene="collapsed_mockup", seed=0) as world, pytest.raises(UnknownNameError, match="mean 'amoeba'"):
        apply_disturbances(world, {"aperture_fit": {"shape": "amoeb", "clearance": 0.02}})


def test_decoys_and_a_tight_aperture_are_not_made_in_one_world():
    with pytest.raises(MissionError, match="aperture_fit or decoys, not both"):
        parse_mission("mission: m\nworld:\n  disturbances:\n    aperture_fit: {shape: u, clearance: 0.02}\n"
                      "    decoys: {wall: mockup_wall_1, x: [-2.2, -1.1], z: [0.45, 1.25]}\ntree: {idle: true}\n")


def test_a_mission_with_a_bad_entry_exits_2_at_its_line():
    result = CliRunner().invoke(cli, ["run", str(MISSION), "--no-log", "-q",
                                      "--set", "world.disturbances.aperture_fit.clearance=[0.03, 0.01]"],
                                env={"COLUMNS": "200"})
    assert result.exit_code == 2, result.output
    assert "aperture_insertion.yaml:18:35:" in result.stderr and "aperture_fit.clearance" in result.stderr
    assert "Traceback" not in result.output
