"""Draw a page's figures in two processes: a forked child draws some while this one draws the rest.

Drawing the figures is most of the time of writing a run report (about 70 ms of CPU per
figure, 16 figures for the shipped runs), and each figure is drawn independently of the
others. :func:`draw_svgs` takes groups of figures (each group a function that yields its
figures, so that a group may redraw one reused figure, as :func:`plots.plot_comparisons`
does) and returns every figure as the text of :func:`~rigval.validation.report.page.svg_text`.
The groups marked ``background`` are drawn by :func:`rigval.validation.beside.beside` (a
forked child, where that helps and is safe) while this process draws the others; the texts
are the same as when one process draws them all. A :class:`Drawing` starts the child as soon
as it is made, so that the child can start before this process's other work (a run's diagnosis)
and draw beside it.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from typing import TYPE_CHECKING

from rigval.validation.beside import beside
from rigval.validation.report.page import svg_text

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["Drawing", "FigureGroup", "draw_svgs"]

#: A function that yields figures; each one is drawn before the next is asked for.
FigureGroup = Callable[[], Iterable["Figure"]]


class Drawing:
    """Figures being drawn: the ``background`` groups from construction on, the rest on request.

    Construct it as soon as the figures' data are known, so that the forked child draws the
    background groups while this process goes on with other work (a run's diagnosis, which no
    figure shows); :meth:`texts` then draws the other groups here and collects the child's.

    Parameters
    ----------
    groups : sequence of callables
        Each returns an iterable of figures (see :data:`FigureGroup`).
    background : iterable of int
        Indices of the groups drawn by a forked child where one helps; otherwise this
        process draws them in :meth:`texts` after the others.
    """

    def __init__(self, groups: Sequence[FigureGroup], background: Iterable[int] = ()) -> None:
        self._groups = list(groups)
        self._away = sorted(set(background))
        self._pending = (beside(lambda: [_draw(self._groups[i]) for i in self._away])
                         if self._away else None)

    def texts(self) -> list[list[str]]:
        """Return, per group, the :func:`~rigval.validation.report.page.svg_text` of its figures.

        Call it once: the background groups' texts are taken from the child.
        """
        texts = {i: _draw(group) for i, group in enumerate(self._groups)
                 if i not in self._away}
        if self._pending is not None:
            texts.update(zip(self._away, self._pending.result(), strict=True))
        return [texts[i] for i in range(len(self._groups))]


def draw_svgs(groups: Sequence[FigureGroup], background: Iterable[int] = ()
              ) -> list[list[str]]:
    """Draw every figure of every group as SVG text, the ``background`` groups beside.

    Parameters
    ----------
    groups, background
        As for :class:`Drawing`; this makes one and collects its texts at once.

    Returns
    -------
    list of list of str
        Per group, the :func:`~rigval.validation.report.page.svg_text` of each of its figures.
    """
    return Drawing(groups, background).texts()


def _draw(group: FigureGroup) -> list[str]:
    return [svg_text(figure) for figure in group()]
