"""TensorBoard scalars of DAgger training: per episode success, labels, beta, loss, removed labels, evaluation.

The writer only reads what the trainer and the runner already computed (an episode's row, the trainer's
update count and last loss), so logging changes no number of a run. It serves the experiment's runner
(one folder per trial, ``out_dir/tb/<method>_seed<k>/``) and a plain :class:`DAggerTrainer` alike::

    with DAggerTensorBoard("runs/tb/mine") as board:
        trainer.train(50, callback=board.callback(trainer))

Read the logs with ``tensorboard --logdir out_dir/tb``.
"""

from __future__ import annotations

import math
import shutil
from collections.abc import Callable, Mapping
from pathlib import Path
from types import TracebackType
from typing import Any

from torch.utils.tensorboard import SummaryWriter

from antmaze_hirl.dagger.trainer import DAggerTrainer, EpisodeRecord

__all__ = ["SCALARS", "DAggerTensorBoard", "trial_log_dir"]

# Tag -> the episode row's column it plots. Rows without a column (an episode without evaluation) skip its tag.
SCALARS: dict[str, str] = {
    "episode/success": "success",
    "episode/expert_cost": "expert_cost",
    "episode/cumulative_expert_cost": "cumulative_expert_cost",
    "episode/beta": "beta",
    "episode/dataset_size": "dataset_size",
    "episode/removed": "removed",
    "episode/attempts": "attempts",
    "eval/success": "eval_success",
    "eval/attempts": "eval_attempts",
}
LOSS_TAG = "train/loss"


def trial_log_dir(out_dir: str | Path, method: str, seed: int) -> Path:
    """A trial's TensorBoard folder, ``out_dir/tb/<method>_seed<k>``: apart from ``trials/``, which resumption reads."""
    return Path(out_dir) / "tb" / f"{method}_seed{seed}"


class DAggerTensorBoard:
    """Writes one training run's scalars, at step = episode index, to a TensorBoard event file.

    Args:
        log_dir: The run's folder. Events already there are removed: a trial that is run again (after an
            interruption) replaces its curves instead of drawing them twice.
    """

    def __init__(self, log_dir: str | Path) -> None:
        self.log_dir = Path(log_dir)
        shutil.rmtree(self.log_dir, ignore_errors=True)
        self._writer = SummaryWriter(str(self.log_dir))
        self._updates_seen = 0

    def write_episode(self, row: Mapping[str, Any], trainer: DAggerTrainer) -> None:
        """Logs an episode's row (its :data:`SCALARS` columns), and the loss if the trainer updated since the last row.

        Args:
            row: The episode's measures, with ``episode`` (the step) and any of the :data:`SCALARS` columns;
                missing or NaN values are skipped.
            trainer: The trainer that ran the episode, after its update (``run_episode`` returned).
        """
        step = int(row["episode"])
        for tag, column in SCALARS.items():
            value = row.get(column)
            if value is not None and not math.isnan(float(value)):
                self._writer.add_scalar(tag, float(value), step)
        if trainer.updates > self._updates_seen and trainer.last_loss is not None:
            self._writer.add_scalar(LOSS_TAG, float(trainer.last_loss), step)
        self._updates_seen = trainer.updates

    def callback(self, trainer: DAggerTrainer) -> Callable[[EpisodeRecord], None]:
        """A ``callback`` for :meth:`DAggerTrainer.train` that logs each episode of ``trainer``."""
        self._updates_seen = trainer.updates  # a trainer that already ran: only its coming updates are new

        def log(record: EpisodeRecord) -> None:
            self.write_episode({**record.to_dict(), "cumulative_expert_cost": trainer.total_expert_cost}, trainer)

        return log

    def close(self) -> None:
        """Flushes the events to disk and closes the file."""
        self._writer.close()

    def __enter__(self) -> DAggerTensorBoard:
        return self

    def __exit__(
        self, kind: type[BaseException] | None, error: BaseException | None, trace: TracebackType | None
    ) -> None:
        self.close()
