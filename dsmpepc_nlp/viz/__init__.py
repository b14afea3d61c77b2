"""Figures and animation: views over logged data; they compute nothing a planner would.

:func:`figures` is how the command line and the benchmarks reach :mod:`.plots` and
:mod:`.results`: importing matplotlib costs about a second of start-up (``python -X importtime
-m dsmpepc_nlp list``) that commands drawing nothing should not pay, so it happens on the
first figure.
"""


def figures(module: str = "plots"):
    """``dsmpepc_nlp.viz.plots`` (or ``.results``), imported on first use with the Agg backend
    (files only: the command line never opens a window)."""
    import importlib

    import matplotlib

    matplotlib.use("Agg")
    return importlib.import_module(f"{__name__}.{module}")
