"""Progress display on stderr (tqdm, imported only when a bar is shown).

`bar(total, desc, enabled)` counts steps of one computation; `Stages` names the stages of
a pipeline run as it goes. Disabled, both are silent no-ops, so a command's stderr stays
empty on success with `--no-progress`.
"""

from __future__ import annotations

import sys


def bar(total: int, desc: str, enabled: bool):
    """A tqdm bar of `total` steps (left behind: no), or a silent stand-in when disabled."""
    if enabled:
        from tqdm import tqdm

        return tqdm(total=total, desc=desc, file=sys.stderr, leave=False)
    return NoBar()


class NoBar:
    """A bar that shows nothing."""

    def update(self, n: int = 1) -> None:
        pass

    def set_postfix_str(self, text: str) -> None:
        pass

    def close(self) -> None:
        pass


class Stages:
    """A progress display of a pipeline's named stages on stderr; as a context manager it
    closes the bar, and clears it when the block raises, so the error stays the only line
    on stderr."""

    def __init__(self, names: list[str], enabled: bool):
        self.bar = None
        if enabled:
            from tqdm import tqdm

            # the bar's last line stays only when every stage is done: a failed or
            # interrupted run leaves its one error line alone on stderr, even when the bar
            # is closed by the garbage collector after the line is printed
            self.bar = tqdm(total=len(names), desc="lathe-mirror", unit="stage", file=sys.stderr, leave=False)

    def start(self, name: str) -> None:
        if self.bar is not None:
            self.bar.set_postfix_str(name)

    def done(self) -> None:
        if self.bar is not None:
            self.bar.update(1)
            if self.bar.n >= self.bar.total:
                self.bar.leave = True

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()

    def __enter__(self) -> "Stages":
        return self

    def __exit__(self, kind, exc, tb) -> None:
        if kind is not None and self.bar is not None:
            self.bar.leave = False  # clear the bar: the error stays the only line on stderr
        self.close()
