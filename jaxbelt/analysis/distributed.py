"""Many processes on JAX's own distributed runtime (``jax.distributed``): start-up and result gathering.

A sweep splits its points over processes, and each process over its local devices. Processes
never exchange data inside the compiled program: every chunk is simulated with local devices
only, then the figures of all processes are gathered (``process_allgather``, which on CPUs needs
the gloo collectives) and process 0 writes the files. Identical points, chunking and programs in
every process make the result of N processes equal that of one (bit for bit on one kind of
machine: each process runs the same compiled program on its share).

An identification splits the tangents of each forward-mode Jacobian over the processes and gathers
the columns (``optimise.CountedResiduals``); its forward runs are repeated in every process.
"""

from __future__ import annotations

import dataclasses

import jax
import numpy as np

from .._errors import ConfigError

__all__ = ["ProcessGroup", "initialize", "process_group", "gather", "broadcast", "tangent_block", "assemble"]


@dataclasses.dataclass(frozen=True)
class ProcessGroup:
    """This process's place among the processes of a run: ``index`` of ``count``."""

    index: int
    count: int

    @property
    def writes(self) -> bool:
        """Process 0 writes the result files (the others compute their share and check in)."""
        return self.index == 0


def initialize(coordinator: str | None = None, num_processes: int | None = None, process_id: int | None = None):
    """Start ``jax.distributed`` before JAX's backend exists.

    All three arguments given: an explicit group (``coordinator`` as ``HOST:PORT``); none: the cluster's
    own description (SLURM, Open MPI, Kubernetes, ... as ``jax.distributed.initialize()`` detects them).
    Some given, some not: an error naming the missing ones.
    """
    given = dict(coordinator=coordinator, num_processes=num_processes, process_id=process_id)
    missing = [k for k, v in given.items() if v is None]
    if 0 < len(missing) < 3:
        raise ConfigError(
            f"distributed run: {', '.join(f'--{k.replace(chr(95), chr(45))}' for k in missing)} missing; give "
            "--coordinator HOST:PORT, --num-processes N and --process-id I together, or none of them on a "
            "cluster that JAX detects (SLURM, Open MPI)"
        )
    if not missing:
        assert num_processes is not None and process_id is not None
        if num_processes < 1 or not 0 <= process_id < num_processes:
            raise ConfigError(
                f"distributed run: --process-id {process_id} with --num-processes {num_processes}: need "
                "num-processes >= 1 and 0 <= process-id < num-processes"
            )
        host, sep, port = str(coordinator).rpartition(":")
        if not sep or not host or not port.isdigit():
            raise ConfigError(f"distributed run: --coordinator {coordinator!r}: expected HOST:PORT, e.g. 10.0.0.1:1234")
    # CPU collectives for the gathering (GPU backends ignore it); asking for the backend here would start it
    jax.config.update("jax_cpu_collectives_implementation", "gloo")
    jax.distributed.initialize(coordinator_address=coordinator, num_processes=num_processes, process_id=process_id)


def process_group() -> ProcessGroup:
    return ProcessGroup(index=jax.process_index(), count=jax.process_count())


def gather(tree, group: ProcessGroup):
    """Every process's ``tree`` (numpy leaves, equal shapes), concatenated along axis 0 in process order."""
    if group.count == 1:
        return tree
    from jax.experimental import multihost_utils

    return jax.tree.map(np.asarray, multihost_utils.process_allgather(tree, tiled=True))


def broadcast(tree, group: ProcessGroup):
    """Process 0's ``tree`` in every process (e.g. the points already done when a sweep resumes)."""
    if group.count == 1:
        return tree
    from jax.experimental import multihost_utils

    return jax.tree.map(np.asarray, multihost_utils.broadcast_one_to_all(tree))


def tangent_block(p: int, group: ProcessGroup) -> np.ndarray:
    """Process ``group.index``'s tangents: rows i k .. i k + k - 1 of the p x p identity, k = ceil(p / count);
    rows beyond p are zero (every process batches k tangents, so all run one program)."""
    k = -(-p // group.count)
    rows = np.arange(group.index * k, (group.index + 1) * k)
    return (rows[:, None] == np.arange(p)[None, :]).astype(float)


def assemble(rows, p: int) -> np.ndarray:
    """The Jacobian (m, p) from every process's rows concatenated in process order (count k, m)."""
    return np.ascontiguousarray(np.asarray(rows)[:p].T)
