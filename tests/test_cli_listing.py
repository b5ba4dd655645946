"""``marsupial skills NAME…`` filters the listing; ``marsupial missions`` lists the shipped missions."""

from __future__ import annotations

import pytest
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


def test_missions_show_each_first_sentence_whole():
    result = invoke("missions")
    text = " ".join(line.strip("│ ").split("│")[-1].strip() for line in result.output.splitlines())
    assert "Narváez et al. 2020 (§V-A, Fig. 13, Tables II-III) in the USAR building" in text
    assert "Arora & Papachristos (§V, Fig. 5) in the collapsed-building mockup" in text
    assert "Palafox et al. (2019, §4.2.1) on the Summit XL driving circles (0.5 m/s, 0.05 rad/s)." in text


def test_skills_index_is_one_row_per_node_without_markup():
    from marsupial.trees.registry import GROUPS, installed

    result = invoke("skills")
    assert result.exit_code == 0, result.output
    nodes = sum(len(installed(kind)) for kind in GROUPS)
    assert len(result.output.splitlines()) < 3 * nodes  # an index, not every parameter of every node
    assert "``" not in result.output and ":class:" not in result.output and ":mod:" not in result.output
    assert "(drive_to on the mother's estimate)" in result.output  # carry's ``drive_to``, plain


def test_skills_detail_has_no_markup_and_lists_the_metrics():
    result = invoke("skills", "contact")
    assert result.exit_code == 0, result.output
    assert "``" not in result.output and ":mod:" not in result.output
    assert "farther than blind_range" in " ".join(result.output.split())
    assert "docking_time (s, each): time from the start of tracking to the lock on Part A" in result.output


@pytest.mark.parametrize("text, sentence", [
    ("Zhao et al. (§3.3) dock. Then more.", "Zhao et al. (§3.3) dock."),
    ("See Fig. 5 and Eq. 3 here. Next one.", "See Fig. 5 and Eq. 3 here."),
    ("One sentence only", "One sentence only"),
    ("Ends at 2.5 m. Next.", "Ends at 2.5 m."),
])
def test_first_sentence_is_not_cut_at_abbreviations(text, sentence):
    from marsupial.trees.listing import first_sentence

    assert first_sentence(text) == sentence


def test_plain_removes_restructuredtext_markup():
    from marsupial.trees.listing import plain

    text = "Uses ``drive_to``, :class:`~marsupial.world.Onboard`, :mod:`.gust_guard`, *this* and **that**::"
    assert plain(text) == "Uses drive_to, Onboard, .gust_guard, this and that:"
    assert plain("2 * x * 3") == "2 * x * 3"
