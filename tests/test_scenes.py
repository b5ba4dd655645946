"""Scenes: every shipped scene loads with its labels, tags, zones and sizes; bad files fail clearly."""

import itertools
import math

import numpy as np
import pybullet
import pytest

from marsupial.api.errors import UnknownNameError
from marsupial.world import World, WorldError
from marsupial.world import scene as scene_module
from marsupial.world.scene import known_scenes

SCENES = ["collapsed_mockup", "marsupial_yard", "open_field", "usar_building"]
CARRIER_RADIUS = 0.35  # m: circle around a Pioneer-3DX-sized base (0.455 x 0.381 m) with a little margin
MAV_PROFILE = (0.10, 0.04)  # m: a 0.1 m-scale micro-scout seen edge-on (Arora et al., Sec. III)


@pytest.fixture(scope="module")
def usar():
    with World("usar_building") as world:
        yield world


@pytest.fixture(scope="module")
def mockup():
    with World("collapsed_mockup") as world:
        yield world


def test_the_four_scenes_are_shipped():
    assert set(SCENES) <= set(known_scenes())


@pytest.mark.parametrize("name", SCENES)
def test_scene_loads_with_visible_static_objects(name):
    with World(name) as world:
        scene = world.scene
        assert scene.name == name and scene.description
        assert scene.floor is not None and scene.floor.analytic
        assert len(scene.objects) < 300
        cid = world.client_id
        for obj in scene.objects.values():
            assert pybullet.getVisualShapeData(obj.body_id, physicsClientId=cid), obj.label
            assert pybullet.getDynamicsInfo(obj.body_id, -1, physicsClientId=cid)[0] == 0.0  # static
        for zone in scene.zones.values():
            assert np.all(zone.size > 0)


def test_usar_building_footprint_rooms_and_doors(usar):
    scene = usar.scene
    lo, hi = scene.aabb("wall")
    assert (hi - lo)[:2] == pytest.approx([30.0, 20.0], abs=0.1)
    assert {"hall", "corridor", "target_room", "lobby"} <= set(scene.zones)
    assert scene.zone("corridor").size[1] >= 2.0 and scene.zone("corridor").size[0] >= 10.0  # a long corridor
    door_frames = {o.label for o in scene.tagged("door_frame") if "_jamb" not in o.label}
    assert door_frames == {"door_entrance", "door_1", "door_2", "door_3", "door_4", "door_5", "door_6"}
    for label in door_frames:
        zone, lintel = scene.zone(label), scene.object(label)
        assert "door_frame" in zone.tags
        along = int(np.argmax(lintel.size[:2]))  # the wall's direction
        assert zone.size[along] >= 1.2  # opening width for the carrier
        # 1.2 m clear along the wall and straight through it, under the lintel
        c = zone.center
        c[2] = 1.0
        for axis, half in ((along, 0.6), (1 - along, zone.size[1 - along] / 2)):
            a, b = c.copy(), c.copy()
            a[axis] -= half
            b[axis] += half
            assert pybullet.rayTest(a.tolist(), b.tolist(), physicsClientId=usar.client_id)[0][0] == -1, label
    assert len(scene.tagged("debris")) >= 30
    assert len(scene.tagged("wall")) >= 15


def test_usar_target_lies_in_the_target_area(usar):
    scene = usar.scene
    (target,) = scene.tagged("target")
    assert target.label == "target"
    assert scene.zone("target_area").contains(target.position)
    assert [z.label for z in scene.zones_at(target.position[:2], tag="room")] == ["target_room"]


def _probe_hits(world, points_xy, radius):
    """Scene labels a carrier-sized cylinder (0.1..1.1 m high) touches anywhere along ``points_xy``."""
    cid = world.client_id
    shape = pybullet.createCollisionShape(pybullet.GEOM_CYLINDER, radius=radius, height=1.0, physicsClientId=cid)
    probe = pybullet.createMultiBody(1.0, shape, -1, [0, 0, 0.6], physicsClientId=cid)
    hits = set()
    try:
        for x, y in points_xy:
            pybullet.resetBasePositionAndOrientation(probe, [x, y, 0.6], [0, 0, 0, 1], physicsClientId=cid)
            for obj in world.scene.objects.values():
                if pybullet.getClosestPoints(probe, obj.body_id, 0.0, physicsClientId=cid):
                    hits.add(obj.label)
    finally:
        pybullet.removeBody(probe, physicsClientId=cid)
    return hits


def _along(path, step):
    out = [path[0]]
    for a, b in itertools.pairwise(path):
        n = max(1, math.ceil(np.linalg.norm(b - a) / step))
        out += [a + (b - a) * k / n for k in range(1, n + 1)]
    return np.array(out)


def test_operator_path_is_clear_for_the_carrier_and_crosses_the_docking_spots(usar):
    """Narvaez et al. Sec. V-A: the guide path leads through a corridor and a door frame to the target."""
    scene = usar.scene
    path = scene.path("operator_path")
    samples = _along(path, 0.1)
    assert _probe_hits(usar, [(-5.2, -5.0)], CARRIER_RADIUS) == {"wall_hall_east_s"}  # the probe does see walls
    assert _probe_hits(usar, samples, CARRIER_RADIUS) == set()
    assert scene.zone("start").contains(path[0])
    crossed = {z.label for p in samples for z in scene.zones_at(p)}
    assert {"hall", "corridor", "door_6", "target_room"} <= crossed
    assert np.linalg.norm(path[-1] - np.asarray(scene.object("target").position[:2])) < 2.5
    # in order: the corridor (first docking), then the door frame (second docking)
    first = {
        label: next(i for i, p in enumerate(samples) if scene.zone(label).contains(p))
        for label in ("corridor", "door_6")
    }
    assert first["corridor"] < first["door_6"]


def test_zones_at_answers_in_or_near_a_corridor_or_door_frame(usar):
    scene = usar.scene
    assert [z.label for z in scene.zones_at([0.0, 0.0], tag="corridor")] == ["corridor"]
    assert scene.zones_at([11.5, -1.0], tag="door_frame") == []
    assert [z.label for z in scene.zones_at([11.5, -1.0], margin=1.5, tag="door_frame")] == ["door_6"]
    assert scene.zones_at([40.0, 40.0]) == []
    with pytest.raises(UnknownNameError, match="Did you mean 'corridor'"):
        scene.zone("coridor")


APERTURES = ["aperture_orthogonal", "aperture_collapsed", "aperture_amoeba", "aperture_u"]


def _open_fraction(world, zone, n=24):
    """Fraction of a grid of rays (along +y) through the zone's face that pass the wall."""
    xs = np.linspace(zone.lo[0], zone.hi[0], n + 2)[1:-1]
    zs = np.linspace(zone.lo[2], zone.hi[2], n + 2)[1:-1]
    starts = [[x, -0.3, z] for z in zs for x in xs]
    ends = [[x, 0.3, z] for z in zs for x in xs]
    hits = pybullet.rayTestBatch(starts, ends, physicsClientId=world.client_id)
    return np.array([h[0] == -1 for h in hits]).reshape(n, n)


def test_mockup_has_four_see_through_apertures_of_the_four_shape_classes(mockup):
    """Arora et al., Table I: orthogonal (convex), collapsed (light concave), amoeba (concave), U (highly concave)."""
    scene = mockup.scene
    assert [z.label for z in scene.zones_tagged("aperture")] == APERTURES
    fractions = {}
    for label in APERTURES:
        zone, clear = scene.zone(label), scene.zone(f"{label}_clear")
        assert zone.size[1] == pytest.approx(0.1) and zone.center[1] == pytest.approx(0.0)  # in the wall plane y = 0
        assert 0.5 < zone.center[2] < 1.1  # within reach of the carrier's arm
        assert np.all(np.asarray(clear.lo) >= np.asarray(zone.lo) - 1e-9) and np.all(
            np.asarray(clear.hi) <= np.asarray(zone.hi) + 1e-9
        )
        # the micro-scout fits through the clear part, but the opening is constricted (< 0.35 m)
        assert clear.size[0] > MAV_PROFILE[0] and clear.size[2] > MAV_PROFILE[1]
        assert max(zone.size) < 0.35
        grid = _open_fraction(mockup, zone)
        fractions[label] = grid.mean()
        assert _open_fraction(mockup, clear).all(), label  # the clear rectangle is really clear
    assert fractions["aperture_orthogonal"] == 1.0
    assert all(0.6 < fractions[k] < 0.95 for k in APERTURES[1:])
    u = _open_fraction(mockup, scene.zone("aperture_u"))
    assert not u[-1, 12] and u[0, 12] and u[-1, 0] and u[-1, -1]  # tongue from the top; bottom bar and both arms open


def test_mockup_corridor_hallway_and_objects_of_interest(mockup):
    scene = mockup.scene
    corridor = scene.zone("corridor")
    assert {"corridor", "caved_in"} <= set(corridor.tags) and corridor.lo[1] >= 0.0  # behind the aperture wall
    assert {o.label for o in scene.tagged("object_of_interest")} == {"fire_extinguisher", "chair"}
    extinguisher, chair = scene.object("fire_extinguisher"), scene.object("chair")
    assert extinguisher.shape == "cylinder" and extinguisher.rgb[0] > 150 > max(extinguisher.rgb[1:])
    hallway = scene.zone("hallway")
    assert hallway.contains(extinguisher.position) and hallway.contains(chair.position)
    assert extinguisher.position[0] > 0 > chair.position[0]  # right and left of the corridor's exit
    assert scene.zone("approach_area").hi[1] <= 0.0


def test_mockup_wall_closes_the_room_but_the_carrier_can_stand_before_each_aperture(mockup):
    """Arora et al. Sec. V: no ground route forward; the apertures are the only way in."""
    xs = np.linspace(-3.45, 3.45, 70)
    hits = pybullet.rayTestBatch(
        [[x, -1.0, 0.3] for x in xs], [[x, 1.0, 0.3] for x in xs], physicsClientId=mockup.client_id
    )
    assert all(h[0] != -1 for h in hits)
    stands = [(z.center[0], -0.8) for z in mockup.scene.zones_tagged("aperture")]
    assert _probe_hits(mockup, stands, CARRIER_RADIUS) == set()


def test_open_field_is_large_flat_and_empty():
    with World("open_field") as world:
        scene = world.scene
        assert min(scene.size) >= 100
        r, g, b = scene.floor.rgb
        assert g >= r and g >= b  # grass, nothing a red-platform detector would pick up
        for obj in scene.objects.values():
            assert obj.tags == ("boundary",) and np.hypot(*obj.position[:2]) > 50


def test_marsupial_yard_is_a_10_m_lab_with_light_walls():
    with World("marsupial_yard") as world:
        scene = world.scene
        lo, hi = scene.aabb("wall")
        assert (hi - lo)[:2] == pytest.approx([10.2, 10.2], abs=0.05)
        assert all(min(o.rgb) > 200 for o in scene.tagged("wall"))
        assert scene.zone("mother_home").contains([0.0, 0.0])


def test_unknown_scene_lists_the_known_ones():
    with pytest.raises(UnknownNameError) as err:
        World("usar_bulding")
    message = str(err.value)
    assert "Did you mean 'usar_building'?" in message
    for name in SCENES:
        assert name in message


GOOD_OBJECT = "{label: crate, shape: box, size: [1, 1, 1], position: [0, 0, 0.5]}"


@pytest.mark.parametrize(
    "body, expected",
    [
        ("objects:\n  - {label: barrel, shape: cone, radius: 0.3, position: [0, 0, 0]}",
         "objects[0] 'barrel': 'shape' must be one of box, cylinder, sphere; got 'cone'"),
        (f"objects:\n  - {GOOD_OBJECT}\n  - {{label: slab, shape: box, position: [1, 1, 1]}}",
         "objects[1] 'slab': missing key 'size' ([x, y, z] in metres (> 0) for a box)"),
        ("objects:\n  - {label: crate, shape: box, size: [1, 1, 1], position: [0, 0]}",
         "objects[0] 'crate': 'position' must be [x, y, z] of the centre in metres; got [0, 0]"),
        ("objects:\n  - {label: crate, size: [1, 1, 1], position: [0, 0, 1], colour: [1, 2, 3]}",
         "objects[0] 'crate': unknown key(s) colour; allowed keys:"),
        ("objects:\n  - {label: crate, size: [1, 1, 1], position: [0, 0, 1], rgb: [300, 0, 0]}",
         "objects[0] 'crate': 'rgb' must be 3 or 4 values in 0..255"),
        (f"objects:\n  - {GOOD_OBJECT}\n  - {GOOD_OBJECT}", "objects[1] 'crate': duplicate label 'crate'"),
        ("objects: {crate: 1}", "'objects' must be a list of mappings"),
        ("zones:\n  - {label: hall, position: [0, 0, 1], size: [4, -1, 2]}",
         "zones[0] 'hall': 'size' must be [x, y, z] extent in metres (> 0)"),
        ("paths:\n  guide: [[0, 0]]", "paths['guide'] must be a list of at least 2 [x, y] points"),
        ("name: other", "'name' is 'other' but the file is broken.yaml"),
        ("floor: {rgb: grey}", "floor: 'rgb' must be 3 or 4 values in 0..255"),
        ("objects: [\n", "not valid YAML"),
        ("- just\n- a list\n", "a scene file is a mapping"),
    ],
)
def test_malformed_scene_names_the_file_entry_and_expectation(tmp_path, monkeypatch, body, expected):
    monkeypatch.setattr(scene_module, "SCENE_DIR", tmp_path)
    path = tmp_path / "broken.yaml"
    path.write_text(body + "\n")
    with pytest.raises(WorldError) as err:
        World("broken")
    message = str(err.value)
    assert message.startswith(str(path))
    assert expected in message
