"""Draw a page's figures in two processes: a forked child draws some while this one draws the rest.

Drawing the figures is most of the time of writing a run report (about 70 ms of CPU per
figure, 16 figures for the shipped runs), and each figure is drawn independently of the
others. :func:`draw_svgs` takes groups of figures (each group a function that yields its
figures, so that a group may redraw one reused figure, as :func:`plots.plot_comparisons`
does) and returns every figure as the text of :func:`~rigval.validation.report.page.svg_text`.
The groups marked ``background`` are drawn in a child forked from this process (it starts
with everything imported and the data in memory, and sends back plain strings), while this
process draws the others; the texts are the same as when one process draws them all.

The child is used only where it can help and is safe: the platform has ``fork``, this process
runs one thread (forking a multi-threaded process can deadlock), it may use more than one CPU,
and it is not itself a worker process (a campaign's or ``rigval demo``'s children already keep
the cores busy). If the child fails or ends without sending its texts, this process draws its
groups itself, so that an error shows here with its traceback.
"""

from __future__ import annotations

import logging
import multiprocessing
import os
import threading
from collections.abc import Callable, Iterable, Sequence
from typing import TYPE_CHECKING

from rigval.validation.report.page import svg_text

if TYPE_CHECKING:
    from multiprocessing.connection import Connection

    from matplotlib.figure import Figure

__all__ = ["FigureGroup", "can_fork", "draw_svgs"]

logger = logging.getLogger(__name__)

#: A function that yields figures; each one is drawn before the next is asked for.
FigureGroup = Callable[[], Iterable["Figure"]]


def can_fork() -> bool:
    """Return whether a forked child may draw figures beside this process (see the module)."""
    if "fork" not in multiprocessing.get_all_start_methods():
        return False
    if threading.active_count() != 1 or multiprocessing.parent_process() is not None:
        return False
    cpus = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return (cpus or 1) > 1


def draw_svgs(groups: Sequence[FigureGroup], background: Iterable[int] = ()
              ) -> list[list[str]]:
    """Draw every figure of every group as SVG text, the ``background`` groups in a child.

    Parameters
    ----------
    groups : sequence of callables
        Each returns an iterable of figures (see :data:`FigureGroup`).
    background : iterable of int
        Indices of the groups a forked child draws, when :func:`can_fork`; otherwise this
        process draws them after the others.

    Returns
    -------
    list of list of str
        Per group, the :func:`~rigval.validation.report.page.svg_text` of each of its figures.
    """
    away = sorted(set(background))
    child = _start(groups, away) if away and can_fork() else None
    texts: dict[int, list[str]] = {i: _draw(groups[i]) for i in range(len(groups))
                                   if child is None or i not in away}
    if child is not None:
        texts.update(zip(away, _receive(*child) or [_draw(groups[i]) for i in away],
                         strict=True))
    return [texts[i] for i in range(len(groups))]


def _draw(group: FigureGroup) -> list[str]:
    return [svg_text(figure) for figure in group()]


def _start(groups: Sequence[FigureGroup], indices: list[int]
           ) -> tuple[Connection, multiprocessing.process.BaseProcess]:
    """Fork the child that draws ``groups[indices]``; return the receiving end and the child."""
    context = multiprocessing.get_context("fork")
    receiver, sender = context.Pipe(duplex=False)
    process = context.Process(target=_child, args=(sender, [groups[i] for i in indices]),
                              name="rigval figures", daemon=True)
    process.start()
    sender.close()  # the child holds the only sending end: its exit means EOF
    return receiver, process


def _child(sender: Connection, groups: list[FigureGroup]) -> None:
    """Draw the groups and send their texts (None when drawing failed: the parent redraws)."""
    with sender:
        try:
            texts: list[list[str]] | None = [_draw(group) for group in groups]
        except Exception:  # the parent draws these groups again and shows the error
            logger.debug("figures drawn in the child failed", exc_info=True)
            texts = None
        sender.send(texts)


def _receive(receiver: Connection, process: multiprocessing.process.BaseProcess
             ) -> list[list[str]] | None:
    """Return the child's texts, or None if it failed or ended without sending them."""
    with receiver:
        try:
            texts = receiver.recv()
        except (EOFError, OSError):
            texts = None
    process.join()
    if texts is None:
        logger.debug("the figure child ended with code %s; drawing its figures here",
                     process.exitcode)
    return texts
