"""The marsupial UGV patrol mission: a recall and a low battery preempt the child's surveys, each followed by a
coordinated docking and the lift, read back from the run's MCAP log."""

from __future__ import annotations

import numpy as np
import pytest

import marsupial


def _preemption(log, by: str) -> dict:
    (event,) = [e for e in log.events_of("preemption") if e["by"] == by]
    return event


@pytest.mark.slow
def test_the_patrol_is_preempted_by_the_recall_then_the_battery_and_docks_twice(tmp_path):
    result = marsupial.run("marsupial_ugv_patrol", log=tmp_path / "patrol.mcap")
    assert result.outcome == "success", result.message
    log = marsupial.read_log(result.log_path)
    recall = _preemption(log, "recalled")  # site 1: the operator's recall at 30 s
    assert recall["preempted"] == "surveying" and recall["why"].startswith("operator(recall)")
    assert recall["t"] == pytest.approx(30.0, abs=0.15)
    low = _preemption(log, "battery low #2")  # site 2: the child's own battery monitor
    assert low["preempted"] == "surveying #2" and low["why"] == "battery_below(0.2, robot=child)"
    t_soc, soc = log.metric("battery_soc", robot="child")
    # the gauge reads whole percent: under 20 % from a charge of 0.195 down
    assert np.interp(low["t"], t_soc, soc) < 0.1955 and np.interp(recall["t"], t_soc, soc) > 0.1955
    outcomes = {e["node"]: (e["t"], e["status"]) for e in log.events_of("outcome")}
    order = [
        "recalled", "child directed", "lifting", "carrying to the site #2", "releasing #2",
        "battery low #2", "child directed #2", "lifting #2",
    ]
    assert [outcomes[n][1] for n in order] == ["SUCCESS"] * len(order)
    times = [outcomes[n][0] for n in order]
    assert times == sorted(times) and times[0] > recall["t"] and times[5] > low["t"]
    # truth: stored at the start and at the end, the mother at the second site, the pack charged while carried
    t, p_child = log.poses("child")
    _, p_mother = log.poses("mother")
    assert p_child[-1][2] == pytest.approx(p_child[0][2], abs=0.01) and p_child[-1][2] > 0.3
    assert p_mother[-1][:2] == pytest.approx([1.5, 0.0], abs=0.1)  # second_site
    lifted, carried = outcomes["lifting"][0], outcomes["carrying to the site #2"][0]
    assert soc[np.searchsorted(t_soc, carried)] > soc[np.searchsorted(t_soc, lifted)]
