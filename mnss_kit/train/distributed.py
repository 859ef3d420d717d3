"""Data-parallel training through ``torch.distributed`` (``torchrun``; gloo on CPU).

Started by ``torchrun --nproc_per_node=N -m mnss_kit.train CONFIG``, every
process reads RANK / WORLD_SIZE / LOCAL_WORLD_SIZE from the environment.  A
plain ``mnss-kit train`` is a world of one and touches none of this.
"""

from __future__ import annotations

import gc
import hashlib
import logging
import os
from dataclasses import dataclass

import torch
import torch.distributed as dist


@dataclass(frozen=True)
class World:
    rank: int = 0
    size: int = 1
    local_size: int = 1

    @property
    def is_main(self) -> bool:
        return self.rank == 0

    @property
    def distributed(self) -> bool:
        return self.size > 1


def setup() -> World:
    """Join the process group when launched by torchrun; a world of one otherwise."""
    size = int(os.environ.get("WORLD_SIZE", "1"))
    if size <= 1:
        return World()
    if not dist.is_initialized():
        backend = "nccl" if torch.cuda.is_available() else "gloo"
        dist.init_process_group(backend)
    return World(rank=dist.get_rank(), size=dist.get_world_size(), local_size=int(os.environ.get("LOCAL_WORLD_SIZE", size)))


def teardown(world: World) -> None:
    if world.distributed and dist.is_initialized():
        # The DDP wrapper holds the process group; collect it first, so that the group's threads are
        # joined now and not while the interpreter shuts down (which aborts the process).
        gc.collect()
        dist.destroy_process_group()


def cpu_threads(world: World, requested: int) -> int:
    """Intra-op threads per process: the request, or this process's share of the idle cores.

    Idle means not counted in the 1-minute load average.  On a busy machine
    one thread per process is much faster than more: OpenMP threads that wait
    for a descheduled sibling at every op barrier stall the whole step.
    """
    if requested > 0:
        cores = os.cpu_count() or 1
        if requested * world.local_size > cores:
            logging.getLogger(__name__).warning(
                "train.threads=%d x %d process(es) exceeds the %d CPU core(s) of this machine: threads will wait for "
                "each other and training runs many times slower (0 picks a share of the idle cores)",
                requested, world.local_size, cores)
        return requested
    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        cores = os.cpu_count() or 1
    try:
        idle = cores - os.getloadavg()[0]
    except OSError:
        idle = cores
    return max(1, min(cores // world.local_size, int(idle // world.local_size)))


def any_rank(world: World, flag: bool) -> bool:
    """True on every rank if ``flag`` is true on any (so all ranks stop at the same step)."""
    if not world.distributed:
        return flag
    t = torch.tensor([1 if flag else 0], dtype=torch.int32)
    dist.all_reduce(t, op=dist.ReduceOp.MAX)
    return bool(t.item())


def barrier(world: World) -> None:
    if world.distributed:
        dist.barrier()


def weights_digest(module: torch.nn.Module) -> str:
    """SHA-256 of every parameter and buffer, in state_dict order (equal digests: equal weights)."""
    h = hashlib.sha256()
    for name, tensor in module.state_dict().items():
        h.update(name.encode())
        h.update(tensor.detach().cpu().contiguous().numpy().tobytes())
    return h.hexdigest()


def gather_strings(world: World, value: str) -> list[str]:
    """``value`` from every rank, in rank order."""
    if not world.distributed:
        return [value]
    out: list[str] = [""] * world.size
    dist.all_gather_object(out, value)
    return out
