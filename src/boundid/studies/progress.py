"""Progress reporting for long stages (simulation, estimation, SDP solves), with rich."""

from __future__ import annotations

from contextlib import contextmanager

from rich.console import Console
from rich.progress import BarColumn, SpinnerColumn, TextColumn, TimeElapsedColumn
from rich.progress import Progress as _RichProgress


class Progress:
    """``with Progress() as p: with p.stage("simulate"): ...``; silent when disabled."""

    def __init__(self, enabled: bool = True):
        self.enabled = enabled
        self._rich = (
            _RichProgress(SpinnerColumn(), TextColumn("{task.description}"), BarColumn(), TimeElapsedColumn(),
                          console=Console(stderr=True), transient=False)
            if enabled else None
        )

    def __enter__(self):
        if self._rich:
            self._rich.__enter__()
        return self

    def __exit__(self, *exc):
        if self._rich:
            self._rich.__exit__(*exc)

    @contextmanager
    def stage(self, description: str):
        if not self._rich:
            yield
            return
        task = self._rich.add_task(description, total=1)
        try:
            yield
        finally:
            self._rich.update(task, completed=1)


QUIET = Progress(enabled=False)
