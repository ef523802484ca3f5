"""The eight symmetric views of an encoded batch, and a learner's outputs read back in the original frame.

The learner trains on the 8 symmetries of the square (:func:`~antmaze_hirl.dagger.features.augment`), so
on the states it was trained on its outputs for a state's 8 images agree once each is mapped back into
the state's own frame; on states it has not seen they need not. :class:`~antmaze_hirl.dagger.strategies.NoiseQuery`
measures that disagreement: of the perturbations tried, the only one that separates unseen from trained
states (docs/guides/protocol.md, ``scripts/alg2_signal.py``).

Everything here is array work; the learner is asked nothing but its ``planar_feature_dim`` and class geometry.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from antmaze_hirl.dagger.features import SYMMETRIES, EncodedBatch, transform_grids, transform_planar
from antmaze_hirl.dagger.network import NEXT_CELL_MOVES


def learner_planar_feature_dim(learner: Any) -> int:
    """How many leading vector features of ``learner``'s encoding are world-frame xy pairs.

    Read from ``learner.planar_feature_dim`` (a :class:`~antmaze_hirl.dagger.HighLevelPolicy` states it).

    Raises:
        ValueError: For a learner that does not state it (names its type).
    """
    value = getattr(learner, "planar_feature_dim", None)
    if isinstance(value, int):
        return value
    raise ValueError(
        f"{type(learner).__name__} states no planar_feature_dim (which features turn with the maze): "
        "symmetric views need it; use symmetries=False"
    )


def class_directions(learner: Any) -> np.ndarray:
    """The xy direction of each of ``learner``'s classes, ``(classes, 2)``: its next-cell moves or heading bins.

    Read from ``learner.settings`` (a :class:`~antmaze_hirl.dagger.LearnerSettings`: ``head``, ``n_directions``),
    or from the learner itself where it has no settings.

    Raises:
        ValueError: For a learner whose classes have no known directions (names its type).
    """
    settings = getattr(learner, "settings", learner)
    head = getattr(settings, "head", None)
    if head == "next_cell":
        return np.asarray(NEXT_CELL_MOVES, dtype=np.float64)
    if head == "heading":
        angles = np.arange(settings.n_directions) * (2 * np.pi / settings.n_directions)
        return np.stack([np.cos(angles), np.sin(angles)], axis=1)
    raise ValueError(
        f"{type(learner).__name__} has classes of unknown directions (head {head!r}): "
        "symmetric views of its class distribution need a next_cell or heading head; use symmetries=False"
    )


def class_permutations(directions: np.ndarray) -> np.ndarray:
    """``(8, classes)``: entry ``[s, c]`` is the class whose direction is symmetry ``s``'s image of class ``c``'s.

    Raises:
        ValueError: If some symmetry does not map the class directions onto themselves.
    """
    directions = np.asarray(directions, dtype=np.float64)
    permutations = []
    for k, flip in SYMMETRIES:
        images = transform_planar(directions, k, flip).astype(np.float64)
        distances = np.linalg.norm(images[:, None, :] - directions[None, :, :], axis=2)
        nearest = distances.argmin(axis=1)
        if not np.allclose(distances[np.arange(len(directions)), nearest], 0.0, atol=1e-5):
            raise ValueError(f"symmetry {(k, flip)} does not permute the class directions")
        permutations.append(nearest)
    return np.stack(permutations)


def symmetric_views(batch: EncodedBatch, planar_feature_dim: int) -> EncodedBatch:
    """The batch seen under each of the 8 symmetries, ``8 * B`` samples, symmetry-major (view ``s`` first).

    Each view transforms what :func:`~antmaze_hirl.dagger.features.augment` transforms: the grids and the
    first ``planar_feature_dim`` vector features (symmetry 0 is the identity).
    """
    grids, vectors = [], []
    for k, flip in SYMMETRIES:
        grids.append(transform_grids(batch.grids, k, flip))
        turned = batch.vectors.copy()
        turned[:, :planar_feature_dim] = transform_planar(turned[:, :planar_feature_dim], k, flip)
        vectors.append(turned)
    return EncodedBatch(np.concatenate(grids).astype(np.float32), np.concatenate(vectors).astype(np.float32))


def probabilities_in_original_frame(probabilities: np.ndarray, permutations: np.ndarray) -> np.ndarray:
    """``(8, B, classes)`` distributions of the 8 views, each read back in the original frame.

    View ``s`` gives original class ``c`` the probability it gives class ``permutations[s, c]``, the
    image of ``c`` under ``s``.
    """
    return np.stack([probabilities[s][:, permutations[s]] for s in range(len(SYMMETRIES))])


def offsets_in_original_frame(offsets: np.ndarray) -> np.ndarray:
    """``(8, B, 2)`` offsets of the 8 views, each mapped back by its symmetry's inverse."""
    back = []
    for s, (k, flip) in enumerate(SYMMETRIES):
        unturned = transform_planar(offsets[s], (4 - k) % 4, False)  # undo the rotation, then the mirror
        back.append(transform_planar(unturned, 0, flip).astype(np.float64))
    return np.stack(back)
