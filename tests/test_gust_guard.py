"""The contact approach's gust guard: unsteady on speed or lateral offset, calm again only after calm_time."""

from marsupial.skills.uav_docking.gust_guard import GuardLimits, GustGuard


def test_calm_uav_is_not_guarded():
    guard = GustGuard(GuardLimits(lateral=0.025, speed=0.08, calm_time=0.5))
    assert not any(guard.update(0.1 * k, 0.01, 0.03) for k in range(20))


def test_a_shove_guards_until_calm_for_calm_time():
    guard = GustGuard(GuardLimits(lateral=0.025, speed=0.08, calm_time=0.5))
    assert not guard.update(0.0, 0.0, 0.0)
    assert guard.update(0.1, 0.0, 0.30)  # shoved at 30 cm/s
    assert "30 cm/s" in guard.reason
    assert guard.update(0.2, 0.0, 0.02)  # calm again, but not for long enough
    assert guard.update(0.6, 0.0, 0.02)
    assert not guard.update(0.7, 0.0, 0.02)  # 0.5 s of calm since 0.2 s


def test_lateral_offset_guards_and_a_new_shove_restarts_the_calm_clock():
    guard = GustGuard(GuardLimits(lateral=0.025, speed=0.08, calm_time=0.5))
    assert guard.update(0.0, 0.04, 0.0)
    assert "4.0 cm off axis" in guard.reason
    assert guard.update(0.3, 0.0, 0.0)
    assert guard.update(0.5, 0.03, 0.0)  # off axis again: the calm restarts
    assert guard.update(0.9, 0.0, 0.0)
    assert guard.update(1.3, 0.0, 0.0)
    assert not guard.update(1.5, 0.0, 0.0)
