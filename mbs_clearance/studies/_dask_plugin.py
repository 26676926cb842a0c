"""What a dask worker needs to run the compiled core without compiling: the client's
compiled libraries and generated model sources, installed into the worker's own cache when
it starts (and when it joins later). Imported only with dask.distributed."""

from __future__ import annotations

from distributed.diagnostics.plugin import WorkerPlugin

__all__ = ["CompiledFiles"]


class CompiledFiles(WorkerPlugin):
    """A worker plugin that installs `files` (`core.build.used_files`) on each worker."""

    name = "mbs-clearance-compiled"

    def __init__(self, files: dict[str, tuple[bytes, str]]):
        self.files = files

    def setup(self, worker) -> None:
        from ..core import build

        build.install(self.files)
