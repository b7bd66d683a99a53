"""Scoring (dsl.md section 4): golden vs itself is perfect; hand-made diffs give exact numbers."""
from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from crashscene.cli import app
from crashscene.dsl import dumps, load_file
from crashscene.evaluation.score import EvalError, case_files, evaluate, evaluate_dirs, score_case

CIREN = Path(__file__).resolve().parents[2] / "examples" / "ciren"
CASE = "100237"  # ego + npc1, one oracle entry: 2 + 6 + (1 + 2*5) + 1 = 20 scored fields


def _gold():
    return load_file(CIREN / CASE / "golden.yaml")


def test_golden_against_itself_is_perfect():
    result = evaluate_dirs(CIREN, CIREN)
    assert result.overall.correct == result.overall.total > 700
    assert all(score.accuracy == 1.0 for score in result.components.values())
    assert result.oracle_precision.precision == 1.0
    assert len(result.cases) == len(list(CIREN.iterdir()))


def test_field_counts_of_one_case():
    checks, _ = score_case(CASE, _gold(), _gold())
    scored = [c for c in checks if c.component != "extension"]
    assert len(scored) == 20
    assert {c.component for c in scored} == {"environment", "road_network", "actors", "oracle"}


def test_hand_made_diffs_give_exact_numbers():
    gold = _gold()
    pred = gold.model_copy(deep=True)
    pred.environment.weather = "clear"  # environment 1/2
    pred.road_network.number_of_lanes = 4  # road_network 4/6 (lanes, signs)
    pred.road_network.traffic_signs = ["stop_sign"]
    pred.actors["npc1"].behavior = "turn_left"  # actors 9/11
    pred.actors["npc1"].position.heading = "from_left"
    pred.oracle[0].actor = "ego"  # oracle 0/1; precision 0/2
    pred.oracle.append(pred.oracle[0].model_copy(update={"code": "CVC_21650", "violation": "wrong_side"}))
    result = evaluate({CASE: (gold, pred)})
    assert (result.components["environment"].correct, result.components["environment"].total) == (1, 2)
    assert (result.components["road_network"].correct, result.components["road_network"].total) == (4, 6)
    assert (result.components["actors"].correct, result.components["actors"].total) == (9, 11)
    assert (result.components["oracle"].correct, result.components["oracle"].total) == (0, 1)
    assert (result.overall.correct, result.overall.total) == (14, 20)
    assert (result.oracle_precision.matched, result.oracle_precision.predicted) == (0, 2)
    assert result.confusion["actors.behavior"]["go_forward"] == {"go_forward": 1, "turn_left": 1}
    assert (result.fields["actors.behavior"].correct, result.fields["actors.behavior"].total) == (1, 2)
    assert (result.fields["oracle"].correct, result.fields["oracle"].total) == (0, 1)
    assert {d.field for d in result.cases[0].diffs} == {
        "environment.weather", "road_network.number_of_lanes", "road_network.traffic_signs",
        "actors.npc1.behavior", "actors.npc1.position.heading", "oracle[CVC_21803@npc1]"}


def test_missing_actor_scores_zero_on_its_fields_and_count():
    gold = _gold()
    pred = gold.model_copy(deep=True)
    del pred.actors["npc1"]
    result = evaluate({CASE: (gold, pred)})
    assert (result.components["actors"].correct, result.components["actors"].total) == (5, 11)


def test_failed_prediction_scores_zero():
    result = evaluate({CASE: (_gold(), None)}, {CASE: "did not validate"})
    assert result.overall.correct == 0 and result.overall.total == 20
    assert result.cases[0].error == "did not validate"


def test_directory_layouts_and_unmatched_cases(tmp_path):
    gold_dir = tmp_path / "gold"
    pred_dir = tmp_path / "pred"
    for case in (CASE, "108812"):
        (gold_dir / case).mkdir(parents=True)
        shutil.copy(CIREN / case / "golden.yaml", gold_dir / case / "golden.yaml")
    pred_dir.mkdir()
    (pred_dir / f"{CASE}.yaml").write_text(dumps(_gold()), encoding="utf-8")
    assert set(case_files(gold_dir)) == {CASE, "108812"}
    with pytest.raises(EvalError, match="no prediction .* 108812"):
        evaluate_dirs(gold_dir, pred_dir)
    result = evaluate_dirs(gold_dir, pred_dir, allow_missing=True)
    assert result.cases[1].error == "no prediction"
    (pred_dir / "108812.yaml").write_text("environment: [", encoding="utf-8")
    result = evaluate_dirs(gold_dir, pred_dir)
    assert "108812.yaml" in result.cases[1].error and result.cases[1].score.correct == 0


def test_cli_json_and_errors(tmp_path):
    runner = CliRunner()
    out = runner.invoke(app, ["eval", "--gold", str(CIREN), "--pred", str(CIREN), "--json"])
    assert out.exit_code == 0, out.output
    data = json.loads(out.stdout)
    assert data["overall"]["accuracy"] == 1.0
    assert set(data["components"]) == {"environment", "road_network", "actors", "oracle"}
    out = runner.invoke(app, ["eval", "--gold", str(CIREN), "--pred", str(tmp_path / "nope")])
    assert out.exit_code == 2 and "not a directory" in out.output


def test_collisions_are_scored_in_order_as_an_extension_with_areas_apart():
    gold = load_file(CIREN / "105203" / "golden.yaml")  # two contacts: ego->npc1 sideswipe, ego->npc2 angle
    pred = gold.model_copy(deep=True)
    pred.collisions = [pred.collisions[0].model_copy(update={"striking_area": "front"})]  # areas wrong, 2nd missing
    result = evaluate({"105203": (gold, pred)})
    assert (result.extensions["collisions"].correct, result.extensions["collisions"].total) == (1, 2)
    assert (result.extensions["collision_areas"].correct, result.extensions["collision_areas"].total) == (0, 2)
    assert result.overall.accuracy == 1.0  # extensions stay out of the overall figure
    swapped = gold.model_copy(deep=True)
    swapped.collisions = list(reversed(swapped.collisions))  # the right contacts in the wrong order
    assert evaluate({"105203": (gold, swapped)}).extensions["collisions"].correct == 0
    untouched = gold.model_copy(update={"collisions": None})  # a golden file without the field scores nothing
    assert evaluate({"105203": (untouched, pred)}).extensions["collisions"].total == 0
