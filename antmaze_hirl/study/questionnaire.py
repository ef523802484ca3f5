"""The NASA-TLX workload questionnaire asked after each trial, and the validation of its answers.

The six items are NASA-TLX's (Hart & Staveland 1988; NASA's rating sheet), in its standard wording,
each rated on a 5-point Likert scale as the paper does. The paper's item list repeats one item by
mistake; this project asks the six standard TLX items once each.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

PAPER_ITEM_NOTE = (
    "The paper's item list repeats one item by mistake; this project asks the six standard TLX items once each."
)

SCALE_MIN = 1
SCALE_MAX = 5
MAX_COMMENT_CHARS = 2000


@dataclass(frozen=True)
class TlxItem:
    """One questionnaire item.

    Attributes:
        key: The item's id in payloads and files.
        title: NASA-TLX's name of the scale.
        question: NASA-TLX's question.
        low_anchor: What a rating of 1 means.
        high_anchor: What a rating of 5 means.
    """

    key: str
    title: str
    question: str
    low_anchor: str = "Very low"
    high_anchor: str = "Very high"


TLX_ITEMS: tuple[TlxItem, ...] = (
    TlxItem("mental_demand", "Mental Demand", "How mentally demanding was the task?"),
    TlxItem("physical_demand", "Physical Demand", "How physically demanding was the task?"),
    TlxItem("temporal_demand", "Temporal Demand", "How hurried or rushed was the pace of the task?"),
    # The one reversed scale: a low rating is good (TLX's "perfect ... failure").
    TlxItem(
        "performance",
        "Performance",
        "How successful were you in accomplishing what you were asked to do?",
        low_anchor="Perfect",
        high_anchor="Failure",
    ),
    TlxItem("effort", "Effort", "How hard did you have to work to accomplish your level of performance?"),
    TlxItem("frustration", "Frustration", "How insecure, discouraged, irritated, stressed, and annoyed were you?"),
)
ITEM_KEYS: tuple[str, ...] = tuple(item.key for item in TLX_ITEMS)


@dataclass(frozen=True)
class QuestionnaireAnswers:
    """A validated questionnaire.

    Attributes:
        ratings: Rating of each item (all six, in :data:`ITEM_KEYS` order), ints from 1 to 5.
        comment: The free-text comment ("" if none).
    """

    ratings: Mapping[str, int]
    comment: str


def _rating(key: str, value: Any) -> int:
    # bool is an int subclass and JSON floats like 3.0 would pass a plain int() check: both are rejected.
    if isinstance(value, bool) or not isinstance(value, int):
        raise ValueError(f"rating of {key!r} must be an int from {SCALE_MIN} to {SCALE_MAX}, got {value!r}")
    if not SCALE_MIN <= value <= SCALE_MAX:
        raise ValueError(f"rating of {key!r} must be from {SCALE_MIN} to {SCALE_MAX}, got {value!r}")
    return value


def validate_answers(payload: dict[str, Any]) -> QuestionnaireAnswers:
    """Checks a submitted questionnaire, ``{"ratings": {item: int, ...}, "comment": str}``.

    Every item is required, once; ``comment`` may be left out (empty).

    Args:
        payload: The submitted JSON object.

    Returns:
        The answers.

    Raises:
        ValueError: On the first problem found, in one line naming the item or field and the value.
    """
    if not isinstance(payload, dict):
        raise ValueError(f"answers must be a JSON object, got {payload!r}")
    unknown_fields = sorted(set(payload) - {"ratings", "comment"})
    if unknown_fields:
        raise ValueError(f"unknown answer fields {unknown_fields}; expected 'ratings' and 'comment'")
    ratings = payload.get("ratings")
    if not isinstance(ratings, dict):
        raise ValueError(f"'ratings' must be an object of item ratings, got {ratings!r}")
    unknown_items = sorted(set(ratings) - set(ITEM_KEYS), key=str)
    if unknown_items:
        raise ValueError(f"unknown questionnaire item {unknown_items[0]!r}; the items are {list(ITEM_KEYS)}")
    for key in ITEM_KEYS:
        if key not in ratings:
            raise ValueError(f"questionnaire item {key!r} is not answered")
    comment = payload.get("comment", "")
    if not isinstance(comment, str):
        raise ValueError(f"comment must be a string, got {comment!r}")
    if len(comment) > MAX_COMMENT_CHARS:
        raise ValueError(f"comment has {len(comment)} characters; at most {MAX_COMMENT_CHARS} are allowed")
    return QuestionnaireAnswers({key: _rating(key, ratings[key]) for key in ITEM_KEYS}, comment)
