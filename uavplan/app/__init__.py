"""The application layer: the use cases, between the command line and the library.

Each use case is a function with typed inputs (a request value) and a typed outcome, and
does the use case's file I/O; the CLI parses the command line, calls one use case and prints
its outcome. Expected outcomes are values (an interrupted search is ``interrupted=True``);
what the user must fix is an exception from :mod:`uavplan.errors`, which the CLI turns into
an exit code.

* :mod:`~uavplan.app.plan` — ``plan``: recognise the input (:func:`~uavplan.app.plan.recognise`)
  and plan a scenario or reroute a QGroundControl plan (:mod:`~uavplan.app.reroute`);
* :mod:`~uavplan.app.check` — ``validate``: check a scenario, and check a flight against a
  scenario (the one mission check; ``render --mission`` uses it too);
* :mod:`~uavplan.app.render` — ``render``: a picture of a scenario, a planned route or a
  mission;
* :mod:`~uavplan.app.convert` — ``convert``: a mission file into another format;
* :mod:`~uavplan.app.importing` — ``import``: buildings from OSM or GIS files into a map;
* :mod:`~uavplan.app.bench` — ``bench``: the paper's algorithm comparison.

While it runs a use case talks to the user through a :class:`~uavplan.app.feedback.Feedback`
(progress, notes, warnings, the Ctrl-C flag), which the CLI supplies.
"""
