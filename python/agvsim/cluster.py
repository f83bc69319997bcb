"""A sweep or a fleet's calibration spread over a cluster engine's workers.

The work is cut as the CLI cuts it for Slurm or Kubernetes (``--shard I/N``): each task
runs one shard with the Python API on a worker, into a scratch folder there, and sends
the shard's files back; the caller writes them under ``out/shards`` and merges them with
the library's own merge (``sweep merge``, ``batch merge``). The merged ``results.csv`` or
``summary.csv`` is the same, byte for byte, as one ``agvsim sweep`` or ``agvsim batch``
on one machine.

Any engine with a submit-and-gather pair does:

- Dask: ``client = dask.distributed.Client(...)``; pass ``client.submit, client.gather``.
- ``concurrent.futures``: ``pool.submit`` and ``lambda fs: [f.result() for f in fs]``.
- Ray: ``lambda f, *a: ray.remote(f).remote(*a)`` and ``ray.get``.

Workers read the scene and the recordings at the paths given: on a cluster they need the
same files at the same paths (a shared file system, as Slurm and Kubernetes clusters
mount; a ``LocalCluster`` shares the machine's). Outputs travel back with the results,
so no shared output folder is needed.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence

import agvsim

Submit = Callable[..., Any]
Gather = Callable[[List[Any]], List[Any]]


def _files_under(folder: Path) -> Dict[str, bytes]:
    """Every file under ``folder``, by its path relative to it."""
    return {
        str(p.relative_to(folder)): p.read_bytes()
        for p in sorted(folder.rglob("*"))
        if p.is_file()
    }


def _write_files(folder: Path, files: Mapping[str, bytes]) -> None:
    for rel, data in files.items():
        path = folder / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(data)


def sweep_shard(
    scene_path: str,
    values: Sequence[str],
    vary: Mapping[str, Any],
    shard: str,
    options: Mapping[str, Any],
    cwd: Optional[str],
) -> Dict[str, bytes]:
    """One task: the sweep's shard ``I/N`` on this worker; returns the shard folder's files."""
    if cwd is not None:
        os.chdir(cwd)
    scene = agvsim.Scene(scene_path, values)
    with tempfile.TemporaryDirectory(prefix="agvsim_shard_") as d:
        agvsim.sweep(scene, vary, shard=shard, out=Path(d) / "shard", **options)
        return _files_under(Path(d) / "shard")


def batch_shard(
    recordings: str,
    scene: Optional[str],
    rig: Optional[str],
    effects: Sequence[str],
    shard: str,
    jobs: int,
    cwd: Optional[str],
) -> Dict[str, bytes]:
    """One task: the fleet's shard ``I/N`` on this worker; returns the shard folder's files."""
    if cwd is not None:
        os.chdir(cwd)
    with tempfile.TemporaryDirectory(prefix="agvsim_shard_") as d:
        out = Path(d) / "shard"
        if scene is not None:
            agvsim.batch_calibrate(recordings, scene, effects=effects, shard=shard, out=out, jobs=jobs)
        else:
            agvsim.batch_diagnose(recordings, rig=rig, effects=effects, shard=shard, out=out, jobs=jobs)
        return _files_under(out)


def _shard_folders(out: Path, results: List[Dict[str, bytes]]) -> List[Path]:
    """Writes each shard's files under ``out/shards/shard_I_of_N``; returns the folders."""
    folders = []
    for i, files in enumerate(results, start=1):
        folder = out / "shards" / f"shard_{i}_of_{len(results)}"
        _write_files(folder, files)
        folders.append(folder)
    return folders


def _gathered(submit: Submit, gather: Gather, shards: int, task: Callable[[str], Any]) -> List[Dict[str, bytes]]:
    if shards < 1:
        raise agvsim.InputError(f"shards={shards}: expected 1 or more")
    futures = [task(f"{i}/{shards}") for i in range(1, shards + 1)]
    return list(gather(futures))


def sweep(
    scene: Any,
    vary: Mapping[str, Any],
    out: os.PathLike,
    shards: int,
    submit: Submit,
    gather: Gather,
    jobs_per_task: int = 1,
    **options: Any,
) -> "agvsim.Table":
    """``agvsim.sweep(scene, vary, ...)`` cut into ``shards`` tasks on the engine's
    workers; returns the merged ``out/results.csv``. ``options`` are :func:`agvsim.sweep`'s
    (``repeat``, ``duration_s``, ``traces``, ``max_runs``)."""
    scene = scene if isinstance(scene, agvsim.Scene) else agvsim.Scene.load(scene)
    out = Path(out)
    options = dict(options, jobs=jobs_per_task)
    cwd = os.getcwd()
    results = _gathered(
        submit, gather, shards,
        lambda s: submit(sweep_shard, str(scene.path), scene.values, dict(vary), s, options, cwd),
    )
    return agvsim.sweep_merge(_shard_folders(out, results), out)


def batch(
    recordings: os.PathLike,
    out: os.PathLike,
    shards: int,
    submit: Submit,
    gather: Gather,
    scene: Optional[os.PathLike] = None,
    rig: Optional[os.PathLike] = None,
    effects: Sequence[str] = ("all",),
    jobs_per_task: int = 1,
) -> "agvsim.Table":
    """``agvsim batch calibrate`` (with ``scene``) or ``batch diagnose`` (else) of a fleet
    cut into ``shards`` tasks on the engine's workers; returns the merged
    ``out/summary.csv``."""
    out = Path(out)
    cwd = os.getcwd()
    effects = [effects] if isinstance(effects, str) else list(effects)
    results = _gathered(
        submit, gather, shards,
        lambda s: submit(
            batch_shard, str(recordings), None if scene is None else str(scene),
            None if rig is None else str(rig), effects, s, jobs_per_task, cwd,
        ),
    )
    return agvsim.batch_merge(_shard_folders(out, results), out)
