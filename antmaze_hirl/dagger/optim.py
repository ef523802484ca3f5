"""torch's foreach Adam step without torch's slow square root of exact zeros: the same weights bit for bit.

The learner takes 200 Adam steps an episode. torch's CPU ``sqrt`` is about ten times slower on an exact zero than
on any other float, and about a third of the second moments of the learner's widest layer stay exactly zero (inputs
that a ReLU or the maze's empty cells keep at zero), so ``_foreach_sqrt`` was about an eighth of a gradient step.
:class:`ZeroSafeAdam` takes the root of ``max(v, tiny)`` instead of ``v`` (``tiny`` the smallest normal float32).
That changes the root only where ``v < tiny``, to at most ``sqrt(tiny)`` (about ``1.1e-19``); Adam then divides it
by ``sqrt(1 - beta2 ** t) >= sqrt(1 - beta2)`` and adds ``eps``, and both roots, so divided, are far below half a
float32 ulp of ``eps``: the denominator comes out ``eps`` either way, to the bit. :meth:`ZeroSafeAdam.step` checks
that bound for the group's ``eps`` and ``beta2`` with the very torch operations it relies on, and otherwise (and for
any option it does not reproduce) runs torch's own step. ``tests/test_optim.py`` trains the learner's network with
both and compares every weight and moment bit for bit.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import torch as th

TINY = float(th.finfo(th.float32).tiny)
"""The smallest normal float32: second moments below it have their root taken as ``sqrt(TINY)``."""


def zero_root_is_absorbed(eps: float, beta2: float) -> bool:
    """Whether ``sqrt(TINY) / sqrt(1 - beta2) + eps`` and ``0 / sqrt(1 - beta2) + eps`` are the same float32.

    Computed with the torch operations :class:`ZeroSafeAdam` uses, at the first step (the smallest bias
    correction, so the largest quotient; later steps only shrink it).
    """
    if not 0.0 <= beta2 < 1.0 or not eps > 0.0:
        return False
    roots = th.tensor([0.0, TINY], dtype=th.float32).sqrt_()
    th._foreach_div_([roots], [math.sqrt(1.0 - beta2)])
    th._foreach_add_([roots], eps)
    return bool(roots[0] == roots[1])


class ZeroSafeAdam(th.optim.Adam):
    """``torch.optim.Adam(..., foreach=True)`` whose step skips torch's slow root of exact zeros (see the module).

    Takes :class:`torch.optim.Adam`'s arguments. Its step is torch's ``_multi_tensor_adam`` for the case it
    reproduces (float32 CPU parameters, no weight decay, amsgrad, maximize, capturable, differentiable or fused,
    plain float hyperparameters, moments already made by a first step of torch's own, no closure); anything else
    runs torch's step unchanged. The state (``step``, ``exp_avg``, ``exp_avg_sq``) is torch's, so a state dict moves
    freely between the two.
    """

    def step(self, closure: Callable[[], float] | None = None) -> float | None:  # type: ignore[override]
        """One Adam update of every parameter with a gradient (torch's own step where not reproduced)."""
        groups = [self._lean_group(group) for group in self.param_groups] if closure is None else [None]
        if any(group is None for group in groups):
            return super().step(closure)
        for group, tensors in zip(self.param_groups, groups, strict=True):
            self._lean_step(group, *tensors)  # type: ignore[misc]
        return None

    def _lean_group(self, group: dict[str, Any]) -> tuple[list[th.Tensor], ...] | None:
        # The group's tensors, as torch's _init_group lists them, if the lean step reproduces torch's for it.
        beta1, beta2 = group["betas"]
        options = (
            group["weight_decay"] == 0
            and not group["amsgrad"]
            and not group["maximize"]
            and not group["capturable"]
            and not group["differentiable"]
            and not group.get("fused")
            and group.get("foreach") is not False
            and not group.get("decoupled_weight_decay", False)
            and all(isinstance(value, float) for value in (group["lr"], beta1, beta2, group["eps"]))
        )
        if not options or not self._absorbs(group["eps"], beta2):
            return None
        params, grads, exp_avgs, exp_avg_sqs, steps = [], [], [], [], []
        for param in group["params"]:
            if param.grad is None:
                continue
            state = self.state.get(param)
            if (
                not state
                or param.grad.is_sparse
                or param.dtype != th.float32
                or param.device.type != "cpu"
                or param.grad.dtype != th.float32
            ):
                return None  # torch makes the moments on the first step, and handles what is not plain float32
            params.append(param)
            grads.append(param.grad)
            exp_avgs.append(state["exp_avg"])
            exp_avg_sqs.append(state["exp_avg_sq"])
            steps.append(state["step"])
        return params, grads, exp_avgs, exp_avg_sqs, steps

    def _absorbs(self, eps: float, beta2: float) -> bool:
        checked = self.__dict__.setdefault("_absorbed", {})
        if (eps, beta2) not in checked:
            checked[(eps, beta2)] = zero_root_is_absorbed(eps, beta2)
        return checked[(eps, beta2)]

    @staticmethod
    def _lean_step(
        group: dict[str, Any],
        params: list[th.Tensor],
        grads: list[th.Tensor],
        exp_avgs: list[th.Tensor],
        exp_avg_sqs: list[th.Tensor],
        steps: list[th.Tensor],
    ) -> None:
        # torch 2.13's _multi_tensor_adam for this case, operation for operation, but for the clamp before the root.
        if not params:
            return
        beta1, beta2 = group["betas"]
        lr, eps = group["lr"], group["eps"]
        with th.no_grad():
            th._foreach_add_(steps, th.tensor(1.0, device="cpu"), alpha=1.0)
            th._foreach_lerp_(exp_avgs, grads, 1 - beta1)
            th._foreach_mul_(exp_avg_sqs, beta2)
            th._foreach_addcmul_(exp_avg_sqs, grads, grads, 1 - beta2)
            bias_correction1 = [1 - beta1 ** step.item() for step in steps]
            bias_correction2 = [1 - beta2 ** step.item() for step in steps]
            step_size = [(lr / correction) * -1 for correction in bias_correction1]
            bias_correction2_sqrt = [correction**0.5 for correction in bias_correction2]
            denominators = th._foreach_clamp_min(exp_avg_sqs, TINY)
            th._foreach_sqrt_(denominators)
            th._foreach_div_(denominators, bias_correction2_sqrt)
            th._foreach_add_(denominators, eps)
            th._foreach_addcdiv_(params, exp_avgs, denominators, step_size)
