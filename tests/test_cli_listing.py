"""``marsupial skills NAME…`` filters the listing; ``marsupial missions`` lists the shipped missions."""

from __future__ import annotations

from click.testing import CliRunner

from marsupial.trees.cli import cli
from marsupial.trees.mission import known_missions


def invoke(*args: str):
    return CliRunner().invoke(cli, list(args), env={"COLUMNS": "200"})


def test_skills_lists_only_the_names_asked_for():
    result = invoke("skills", "hover", "battery_below")
    assert result.exit_code == 0, result.output
    assert "skill hover" in result.output and "condition battery_below" in result.output
    assert "skill goto" not in result.output and "skill track" not in result.output
    assert len(result.output.splitlines()) < 40  # not the whole catalogue


def test_skills_with_an_unknown_name_exits_2_with_a_suggestion():
    result = invoke("skills", "hovr")
    assert result.exit_code == 2
    assert "unknown skill or condition 'hovr'" in result.output and "did you mean 'hover'?" in result.output


def test_bracketed_text_is_printed_literally():
    result = invoke("skills", "goto")  # rich markup would take "[float, float, float]" for a style tag and drop it
    assert "tuple[float, float, float]" in result.output.replace("\n", "").replace(" ", "").replace(",", ", ")


def test_missions_lists_every_shipped_mission_with_its_robots():
    result = invoke("missions")
    assert result.exit_code == 0, result.output
    for name in known_missions():
        assert name in result.output
    assert "uav: bebop2" in result.output and "carrier: mobile_manipulator" in result.output
