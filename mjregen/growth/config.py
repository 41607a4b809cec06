"""The configuration of a neural cellular automaton: its grid, its network's shape and the
layout of its genome (what a checkpoint stores to rebuild it)."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Literal

from mjregen.grid import N_MATERIALS

GRID_SIZE = {2: 7, 3: 9}  # the paper's grids, border included
NetKind = Literal["ff", "lstm"]


@dataclass(frozen=True)
class NCAConfig:
    """Everything needed to rebuild an NCA.

    Attributes:
      dim: 2 (grid ``[x, z]``) or 3 (grid ``[x, y, z]``).
      kind: "ff" (in→hidden→hidden→6, tanh) or "lstm" (in→lstm_input tanh→LSTM→6).
      hidden: width of the feed-forward hidden layers / LSTM hidden size.
      lstm_input: width of the tanh layer in front of the LSTM.
      steps: growth steps.
      grid_size: cells per axis, border included; 0 means the paper's (9 in 3D, 7 in 2D).
      alive_threshold: a cell lives iff its neighbourhood's largest alpha exceeds this.
      input_scale: the network input is divided by this.
    """

    dim: int = 3
    kind: NetKind = "ff"
    hidden: int = 64
    lstm_input: int = 32
    steps: int = 10
    grid_size: int = 0
    alive_threshold: float = 0.1
    input_scale: float = 3.0

    def __post_init__(self) -> None:
        if not isinstance(self.dim, int) or isinstance(self.dim, bool) \
                or self.dim not in GRID_SIZE:
            raise ValueError(f"NCA dim must be 2 or 3, got {self.dim!r}")
        if self.kind not in ("ff", "lstm"):
            raise ValueError(f"NCA kind must be 'ff' or 'lstm', got {self.kind!r}")
        if self.grid_size == 0:
            object.__setattr__(self, "grid_size", GRID_SIZE[self.dim])
        for name in ("hidden", "lstm_input", "steps"):
            value = getattr(self, name)
            if not isinstance(value, int) or isinstance(value, bool) or value < 1:
                raise ValueError(f"NCA {name} must be a positive integer, got {value!r}")
        if not isinstance(self.grid_size, int) or self.grid_size < 3 or self.grid_size % 2 == 0:
            raise ValueError(f"NCA grid_size must be an odd integer >= 3, got {self.grid_size!r}")
        for name in ("input_scale", "alive_threshold"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) \
                    or not math.isfinite(value):
                raise ValueError(f"NCA {name} must be a finite number, got {value!r}")
        if self.input_scale <= 0:
            raise ValueError(f"NCA input_scale must be positive, got {self.input_scale!r}")

    @property
    def n_inputs(self) -> int:
        """Network inputs per cell: 3^dim states then 3^dim alphas."""
        return 2 * 3**self.dim

    @property
    def n_outputs(self) -> int:
        """One score per material plus the alpha channel."""
        return N_MATERIALS + 1

    @property
    def grid_shape(self) -> tuple[int, ...]:
        return (self.grid_size,) * self.dim

    @property
    def parameter_layout(self) -> tuple[tuple[str, tuple[int, ...]], ...]:
        """``(name, shape)`` of every parameter of the cell network, in genome order: the
        paper's ``MorphNet`` (torch's ``named_parameters`` of
        `mjregen.growth.networks.CellNetwork`)."""
        n_in, hidden, n_out = self.n_inputs, self.hidden, self.n_outputs
        if self.kind == "ff":
            return (("linear1.weight", (hidden, n_in)), ("linear1.bias", (hidden,)),
                    ("linear2.weight", (hidden, hidden)), ("linear2.bias", (hidden,)),
                    ("linear3.weight", (n_out, hidden)), ("linear3.bias", (n_out,)))
        width, gates = self.lstm_input, 4 * hidden
        return (("linear1.weight", (width, n_in)), ("linear1.bias", (width,)),
                ("lstm.weight_ih_l0", (gates, width)), ("lstm.weight_hh_l0", (gates, hidden)),
                ("lstm.bias_ih_l0", (gates,)), ("lstm.bias_hh_l0", (gates,)),
                ("linear2.weight", (n_out, hidden)), ("linear2.bias", (n_out,)))

    @property
    def genome_size(self) -> int:
        """Genes: the cell network's parameters."""
        return sum(math.prod(shape) for _, shape in self.parameter_layout)

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, values: dict) -> NCAConfig:
        """The configuration `to_dict` wrote.

        Raises:
          ValueError: not a JSON object, an unknown key, or a value of the wrong type.
        """
        if not isinstance(values, dict):
            raise ValueError(f"an NCA config is a JSON object, got {type(values).__name__}")
        unknown = set(values) - set(cls.__dataclass_fields__)
        if unknown:
            raise ValueError(f"unknown NCA config keys: {sorted(unknown)}")
        return cls(**values)
