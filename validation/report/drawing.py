"""Draw a page's figures in standby children while this process writes the rest of the report.

Drawing the figures is most of the time of writing a run report (about 70 ms of CPU per
figure, 16 figures for the shipped runs) and matplotlib's import another third of a second;
each figure is drawn independently of the others. :func:`standby_drawers` forks children
(:class:`rigval.validation.beside.Standby`) at the start of a command; they import the
plotting modules (:data:`DRAWING_MODULES`) while this process runs the pipeline, so that this
process never imports matplotlib. A page's :class:`Drawing` then hands its figure groups (a
module-level function and its small, picklable inputs) to the drawer with the fewest figures
so far (:class:`Drawers`, shared by the pages of one command) and collects their SVG texts
(:func:`~rigval.validation.report.page.svg_text`) by group name. Without drawers (a worker
process, one CPU, no ``fork``) every group is drawn in this process when its texts are asked
for; the texts are the same either way.
"""

from __future__ import annotations

import contextlib
import hashlib
import pickle
from collections.abc import Callable, Iterable, Iterator, Sequence
from typing import TYPE_CHECKING, TypeVar

from rigval.validation.beside import Pending, Standby, pickled

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["DRAWERS", "DRAWING_MODULES", "Drawers", "Drawing", "GroupFunction",
           "draw_texts", "hand_drawers", "standby_drawers"]

#: Modules a standby drawer imports while this process does other work: numpy, matplotlib
#: and the drawing modules, which import nothing else (the figures' inputs are plain arrays,
#: :mod:`rigval.validation.report.figure_inputs`).
DRAWING_MODULES = ("rigval.validation.report.figure_groups", "rigval.validation.report.plots",
                   "rigval.validation.report.sketch", "rigval.validation.report.page",
                   "matplotlib.backends.backend_svg")

#: Two drawers: on two cores, they and this process (the diagnosis, the data files) share
#: the time after the pipeline about evenly.
DRAWERS = 2

Inputs = TypeVar("Inputs")

#: ``function(inputs, names)``: the SVG texts of each named figure group, in the order of
#: ``names``. A module-level function (it travels to the drawer pickled, by name).
GroupFunction = Callable[[Inputs, tuple[str, ...]], list[list[str]]]


class Drawers:
    """Standby drawers, each handed the next figure groups while it has the fewest figures.

    Parameters
    ----------
    standbys : sequence of Standby
        The drawers' children (:func:`standby_drawers`).
    """

    def __init__(self, standbys: Sequence[Standby]) -> None:
        self._standbys = tuple(standbys)
        self._figures = [0] * len(self._standbys)
        self._handed: dict[bytes, Pending[list[list[str]]]] = {}

    def each(self) -> list[Drawers]:
        """Return one :class:`Drawers` per drawer, to hand to a process of its own each.

        A campaign's run processes (:mod:`rigval.validation.campaign.processes`) each draw with
        one drawer forked for them (:func:`hand_drawers`): a drawer serves one process only.
        """
        return [Drawers((standby,)) for standby in self._standbys]

    def submit(self, function: GroupFunction[Inputs], inputs: Inputs, names: tuple[str, ...],
               figures: int) -> Pending[list[list[str]]]:
        """Hand ``function(inputs, names)``, about ``figures`` figures, to the least busy drawer.

        A call equal to one handed before (the same function, names and pickled inputs: the
        same figures, as drawing is deterministic) is not drawn again: its texts are shared.
        """
        try:
            key = hashlib.sha256(pickled((function, inputs, names))).digest()
        except (pickle.PicklingError, TypeError, AttributeError):  # drawn afresh, here
            key = b""
        if key in self._handed:
            return self._handed[key]
        if self._standbys:
            least = min(range(len(self._standbys)), key=self._figures.__getitem__)
            self._figures[least] += figures
            pending = self._standbys[least].submit(function, inputs, names)
        else:
            pending = Pending(None, function, (inputs, names))
        if key:
            self._handed[key] = pending
        return pending


#: The drawers the process that forked this one handed it (:func:`hand_drawers`).
_handed: Drawers | None = None


def hand_drawers(drawers: Drawers) -> None:
    """Have :func:`standby_drawers` in this process yield ``drawers`` instead of forking.

    Called in a process forked to validate a run (a campaign's run process, which may not
    fork drawers of its own, :mod:`rigval.validation.beside`) with drawers its parent forked
    for it (:meth:`Drawers.each`) before it imported the pipeline. They serve this process
    alone, and the parent ends them.
    """
    global _handed
    _handed = drawers


@contextlib.contextmanager
def standby_drawers(count: int = DRAWERS) -> Iterator[Drawers]:
    """Fork ``count`` drawers now, importing :data:`DRAWING_MODULES` once; end them on exit.

    The first drawer imports the modules, then forks the others from itself
    (:meth:`~rigval.validation.beside.Standby.group`): one import's CPU, not ``count``.

    Where forking cannot help (see :mod:`rigval.validation.beside`), the drawers have no
    child and their figures are drawn in this process. In a process handed drawers by its
    parent (:func:`hand_drawers`) those are yielded, and left to the parent to end.

    Yields
    ------
    Drawers
        Hand them to each :class:`Drawing` of the command.
    """
    if _handed is not None:
        yield _handed
        return
    standbys = Standby.group(count, DRAWING_MODULES)
    with standbys[0]:  # closing the first closes the others
        yield Drawers(standbys)


class Drawing:
    """One page's figure groups being drawn as SVG text, by name, by the drawers or here.

    Parameters
    ----------
    drawers : Drawers, optional
        From :func:`standby_drawers`; none: every group is drawn here when asked for.
    """

    def __init__(self, drawers: Drawers | None = None) -> None:
        self._drawers = Drawers(()) if drawers is None else drawers
        self._groups: dict[str, list[tuple[Pending[list[list[str]]], int]]] = {}

    def start(self, function: GroupFunction[Inputs], inputs: Inputs, names: Iterable[str],
              figures: int = 1) -> None:
        """Have a drawer draw the groups ``names`` (about ``figures`` figures).

        The drawer calls ``function(inputs, names)``. A group started again (a share of its
        figures, other inputs) continues it: its texts are those of every start, in order.
        """
        names = tuple(names)
        pending = self._drawers.submit(function, inputs, names, figures)
        for i, name in enumerate(names):
            self._groups.setdefault(name, []).append((pending, i))

    def __contains__(self, name: object) -> bool:
        return name in self._groups

    def texts(self, name: str) -> list[str]:
        """Return the SVG texts of the group ``name`` (waiting for its drawers)."""
        return [text for pending, index in self._groups[name]
                for text in pending.result()[index]]


def draw_texts(figures: Iterable[Figure]) -> list[str]:
    """Return the :func:`~rigval.validation.report.page.svg_text` of each figure in turn.

    A group may yield one reused figure redrawn (as
    :func:`~rigval.validation.report.plots.plot_comparisons` does): each is drawn before the
    next is asked for.
    """
    from rigval.validation.report.page import svg_text

    return [svg_text(figure) for figure in figures]
