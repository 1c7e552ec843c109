"""K copies of the face classifier's network, trained side by side in one batched pass.

Imported lazily (it imports torch) by :mod:`scribbleseg_core.network`.
"""

from __future__ import annotations

import math

import torch
import torch.nn as nn
import torch.nn.functional as F


class MLPEnsemble(nn.Module):
    """`members` independent MLPs ``d → h1 → h2 → c`` (ReLU, dropout after each ReLU), each
    the network of :func:`scribbleseg_core.network.build_mlp`, their weights stacked so one
    batched matrix product runs all of them.

    Parameters
    ----------
    members : int
        K, at least 1.
    d, c : int
        Inputs and labels.
    hidden : tuple of int
        (h1, h2).
    dropout : float
        Dropout after each ReLU, in training only; each member draws its own mask.

    Notes
    -----
    Every layer is initialized as :class:`torch.nn.Linear` is (uniform in ±1/sqrt(fan in)),
    each member from the torch generator in turn, so members start apart.
    """

    def __init__(self, members: int, d: int, c: int, hidden: tuple[int, int], dropout: float = 0.0):
        super().__init__()
        if members < 1:
            raise ValueError(f"an ensemble needs at least one member; got {members}")
        self.members = int(members)
        self.dropout = float(dropout)
        sizes = (int(d), *(int(h) for h in hidden), int(c))
        self.weights = nn.ParameterList()
        self.biases = nn.ParameterList()
        for fan_in, fan_out in zip(sizes[:-1], sizes[1:]):
            bound = 1.0 / math.sqrt(fan_in)
            self.weights.append(nn.Parameter(torch.empty(self.members, fan_in, fan_out).uniform_(-bound, bound)))
            self.biases.append(nn.Parameter(torch.empty(self.members, 1, fan_out).uniform_(-bound, bound)))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        """Logits of every member.

        Parameters
        ----------
        x : (B, d) or (K, B, d) tensor
            One batch for all members, or a batch per member.

        Returns
        -------
        (K, B, c) tensor
        """
        h = x.expand(self.members, *x.shape) if x.dim() == 2 else x
        last = len(self.weights) - 1
        for i, (W, b) in enumerate(zip(self.weights, self.biases)):
            h = torch.baddbmm(b, h, W)
            if i < last:
                h = F.relu(h)
                if self.dropout > 0:
                    h = F.dropout(h, self.dropout, self.training)
        return h

    def log_proba(self, x: torch.Tensor) -> torch.Tensor:
        """Log of the members' mean class probabilities, (B, c), for inputs (B, d)."""
        logp = torch.log_softmax(self.forward(x), dim=2)
        return torch.logsumexp(logp, dim=0) - math.log(self.members)
