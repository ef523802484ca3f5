import pytest

from antmaze_hirl.study import questionnaire
from antmaze_hirl.study.questionnaire import ITEM_KEYS, TLX_ITEMS, QuestionnaireAnswers, validate_answers

GOOD = {key: 1 + i % 5 for i, key in enumerate(ITEM_KEYS)}


def test_items_are_the_six_standard_tlx_items():
    assert ITEM_KEYS == ("mental_demand", "physical_demand", "temporal_demand", "performance", "effort", "frustration")
    questions = {item.key: item.question for item in TLX_ITEMS}
    assert questions["mental_demand"] == "How mentally demanding was the task?"
    assert questions["physical_demand"] == "How physically demanding was the task?"
    assert questions["temporal_demand"] == "How hurried or rushed was the pace of the task?"
    assert questions["performance"] == "How successful were you in accomplishing what you were asked to do?"
    assert questions["effort"] == "How hard did you have to work to accomplish your level of performance?"
    assert questions["frustration"] == "How insecure, discouraged, irritated, stressed, and annoyed were you?"
    anchors = {item.key: (item.low_anchor, item.high_anchor) for item in TLX_ITEMS}
    assert anchors.pop("performance") == ("Perfect", "Failure")
    assert set(anchors.values()) == {("Very low", "Very high")}
    assert questionnaire.PAPER_ITEM_NOTE in " ".join(questionnaire.__doc__.split())


def test_valid_answers():
    answers = validate_answers({"ratings": dict(reversed(GOOD.items())), "comment": "fine"})
    assert answers == QuestionnaireAnswers(GOOD, "fine")
    assert list(answers.ratings) == list(ITEM_KEYS)
    assert validate_answers({"ratings": GOOD}).comment == ""
    assert validate_answers({"ratings": GOOD, "comment": "x" * 2000}).comment == "x" * 2000


@pytest.mark.parametrize(
    ("payload", "message"),
    [
        ({"ratings": {**GOOD, "effort": 0}}, "'effort' must be from 1 to 5, got 0"),
        ({"ratings": {**GOOD, "effort": 6}}, "'effort' must be from 1 to 5, got 6"),
        ({"ratings": {**GOOD, "effort": True}}, "'effort' must be an int from 1 to 5, got True"),
        ({"ratings": {**GOOD, "effort": 3.0}}, "'effort' must be an int from 1 to 5, got 3.0"),
        ({"ratings": {**GOOD, "effort": float("nan")}}, "'effort' must be an int from 1 to 5, got nan"),
        ({"ratings": {**GOOD, "effort": "3"}}, "'effort' must be an int from 1 to 5, got '3'"),
        ({"ratings": {**GOOD, "effort": None}}, "'effort' must be an int from 1 to 5, got None"),
        ({"ratings": {k: v for k, v in GOOD.items() if k != "frustration"}}, "'frustration' is not answered"),
        ({"ratings": {**GOOD, "fun": 3}}, "unknown questionnaire item 'fun'"),
        ({"ratings": [1, 2, 3]}, "'ratings' must be an object"),
        ({}, "'ratings' must be an object"),
        ({"ratings": GOOD, "comment": 5}, "comment must be a string, got 5"),
        ({"ratings": GOOD, "comment": "x" * 2001}, "comment has 2001 characters"),
        ({"ratings": GOOD, "trial": 1}, r"unknown answer fields \['trial'\]"),
        ([1], "answers must be a JSON object"),
    ],
)
def test_invalid_answers(payload, message):
    with pytest.raises(ValueError, match=message) as error:
        validate_answers(payload)
    assert "\n" not in str(error.value)
