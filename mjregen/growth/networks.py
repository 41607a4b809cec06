"""The cell networks of the paper's NCAs and their genomes: one cell's network (`CellNetwork`,
the paper's ``MorphNet`` layout), a whole population's as batched matmuls
(`PopulationNetworks`), and genome <-> network, exact: a genome is the float32 vector of
``torch.nn.utils.parameters_to_vector`` of `CellNetwork`."""

from __future__ import annotations

import numpy as np
import torch
from torch import nn
from torch.nn.utils import parameters_to_vector, vector_to_parameters

from mjregen.errors import InvalidGenomeError
from mjregen.growth.config import NCAConfig


class CellNetwork(nn.Module):
    """One cell's network, laid out like the paper's ``MorphNet`` (same parameter order:
    `NCAConfig.parameter_layout`).

    `forward` maps inputs ``(N, n_inputs)`` (already divided by `input_scale`) and, for
    LSTMs, a memory ``(h, c)`` each ``(N, hidden)`` to outputs ``(N, 6)`` and the new memory.
    """

    def __init__(self, config: NCAConfig) -> None:
        super().__init__()
        self.kind = config.kind
        if config.kind == "ff":
            self.linear1 = nn.Linear(config.n_inputs, config.hidden)
            self.linear2 = nn.Linear(config.hidden, config.hidden)
            self.linear3 = nn.Linear(config.hidden, config.n_outputs)
        else:
            self.linear1 = nn.Linear(config.n_inputs, config.lstm_input)
            self.lstm = nn.LSTM(config.lstm_input, config.hidden)
            self.linear2 = nn.Linear(config.hidden, config.n_outputs)

    def forward(
        self, x: torch.Tensor, memory: tuple[torch.Tensor, torch.Tensor] | None = None
    ) -> tuple[torch.Tensor, tuple[torch.Tensor, torch.Tensor] | None]:
        if self.kind == "ff":
            x = torch.tanh(self.linear2(torch.tanh(self.linear1(x))))
            return self.linear3(x), None
        assert memory is not None, "an LSTM cell network needs its memory (h, c)"
        h, c = memory
        x, (h, c) = self.lstm(torch.tanh(self.linear1(x)).unsqueeze(0), (h.unsqueeze(0), c.unsqueeze(0)))
        return self.linear2(x[0]), (h[0], c[0])


def genome_to_network(config: NCAConfig, genome: np.ndarray) -> CellNetwork:
    """A `CellNetwork` whose parameters are exactly `genome` (float32, ``(G,)``)."""
    genome = check_genomes(config, genome)
    network = CellNetwork(config)
    vector_to_parameters(torch.from_numpy(genome.copy()), network.parameters())
    return network


def network_to_genome(network: CellNetwork) -> np.ndarray:
    """The flat float32 genome ``(G,)`` of `network` (``parameters_to_vector`` order)."""
    return parameters_to_vector(network.parameters()).detach().numpy().astype(np.float32)


def check_genomes(config: NCAConfig, genomes: np.ndarray) -> np.ndarray:
    """Validate genomes ``(G,)`` or ``(P, G)`` for `config`; return them as float32."""
    array = np.asarray(genomes)
    if array.ndim not in (1, 2) or array.shape[-1] != config.genome_size:
        raise InvalidGenomeError(
            f"genome shape {array.shape} does not fit a {config.dim}D {config.kind} NCA with "
            f"hidden={config.hidden}: expected ({config.genome_size},) or (P, {config.genome_size})"
        )
    if not np.issubdtype(array.dtype, np.floating) and not np.issubdtype(array.dtype, np.integer):
        raise InvalidGenomeError(f"genome must be numeric, got dtype {array.dtype}")
    if not np.all(np.isfinite(array)):
        raise InvalidGenomeError("genome contains NaN or infinite values")
    return np.ascontiguousarray(array, dtype=np.float32)  # any strides in, C order out


def random_genomes(
    config: NCAConfig, n: int, *, seed: int | np.random.Generator, std: float = 0.1
) -> np.ndarray:
    """The paper's initial genomes: ``(n, G)`` float32, every gene N(0, std²)."""
    rng = np.random.default_rng(seed)
    return rng.normal(0.0, std, size=(n, config.genome_size)).astype(np.float32)


class PopulationNetworks:
    """The cell networks of a whole population, evaluated with batched matmuls.

    Args:
      config: the NCA configuration.
      genomes: float32 ``(P, G)``.
    """

    def __init__(self, config: NCAConfig, genomes: np.ndarray) -> None:
        genomes = check_genomes(config, genomes)
        if genomes.ndim == 1:
            genomes = genomes[None]
        flat = torch.tensor(genomes)  # a copy: genomes may be read-only
        sizes = [int(np.prod(shape)) for _, shape in config.parameter_layout]
        params = {
            name: chunk.reshape(len(genomes), *shape)
            for (name, shape), chunk in zip(config.parameter_layout,
                                            torch.split(flat, sizes, dim=1))
        }
        self.kind = config.kind
        # Per layer: weight as (P, in, out), contiguous, and bias as (P, 1, out).
        self.layers: dict[str, tuple[torch.Tensor, torch.Tensor]] = {}
        for name in ("linear1", "linear2", "linear3"):
            if f"{name}.weight" in params:
                self.layers[name] = (
                    params[f"{name}.weight"].transpose(1, 2).contiguous(),
                    params[f"{name}.bias"].unsqueeze(1),
                )
        if config.kind == "lstm":
            # Both LSTM matmuls in one, [x, h] @ [W_ih; W_hh]^T + (b_ih + b_hh), with the gate
            # rows reordered from torch's (i, f, g, o) to (i, f, o, g) so that one sigmoid
            # covers a contiguous block.
            hidden = config.hidden
            order = torch.cat([torch.arange(0, 2 * hidden), torch.arange(3 * hidden, 4 * hidden),
                               torch.arange(2 * hidden, 3 * hidden)])
            weight = torch.cat([params["lstm.weight_ih_l0"], params["lstm.weight_hh_l0"]], dim=2)
            bias = params["lstm.bias_ih_l0"] + params["lstm.bias_hh_l0"]
            self.layers["lstm"] = (
                weight[:, order].transpose(1, 2).contiguous(),
                bias[:, order].unsqueeze(1),
            )

    def _linear(self, name: str, x: torch.Tensor) -> torch.Tensor:
        """``x @ W.T + b`` per individual: x ``(P, N, in)`` -> ``(P, N, out)``."""
        weight, bias = self.layers[name]
        return torch.baddbmm(bias, x, weight)

    def _output(self, name: str, x: torch.Tensor) -> torch.Tensor:
        """The output layer (6 outputs), one matmul per individual: a batched matmul this
        narrow rounds differently where an individual's output block is not aligned in
        memory (every other one), so a robot would depend on its place in the population."""
        weight, bias = self.layers[name]
        return torch.stack([torch.addmm(bias[i, 0], x[i], weight[i]) for i in range(len(x))])

    def __call__(
        self, x: torch.Tensor, memory: tuple[torch.Tensor, torch.Tensor] | None
    ) -> tuple[torch.Tensor, tuple[torch.Tensor, torch.Tensor] | None]:
        """Inputs ``(P, N, n_inputs)``, memory ``(h, c)`` each ``(P, N, hidden)`` ->
        outputs ``(P, N, 6)`` and the new memory (None for feed-forward)."""
        if self.kind == "ff":
            x = torch.tanh(self._linear("linear1", x))
            x = torch.tanh(self._linear("linear2", x))
            return self._output("linear3", x), None
        assert memory is not None
        h, c = memory
        x = torch.tanh(self._linear("linear1", x))
        gates = self._linear("lstm", torch.cat([x, h], dim=-1))
        hidden = h.shape[-1]
        sig = torch.sigmoid(gates[..., : 3 * hidden])
        in_gate, forget_gate, out_gate = sig.split(hidden, dim=-1)
        c = torch.addcmul(forget_gate * c, in_gate, torch.tanh(gates[..., 3 * hidden :]))
        h = torch.tanh(c).mul_(out_gate)
        return self._output("linear2", h), (h, c)
