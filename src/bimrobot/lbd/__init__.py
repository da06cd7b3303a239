"""Linked building data: the construction knowledge graph of thesis chapter 5 (fig. 5.5).

* :mod:`bimrobot.schedule.csv`: ``Schedule`` / ``Activity``, read from the schedule CSV
  (``load_schedule_csv``, validated) or an IFC work schedule (``load_schedule_ifc``).
* :mod:`bimrobot.lbd.graph`: ``build_graph(model, schedule) -> ConstructionGraph``: BOT topology,
  DiCon activities and live states, SPARQL queries from ``lbd/queries/*.rq``, Turtle / JSON-LD out.
* :mod:`bimrobot.lbd.store`: the triple stores behind it (rdflib in memory, Oxigraph on disk, a remote
  SPARQL endpoint).
* :mod:`bimrobot.schedule.msproject`: Microsoft Project XML (MSPDI) schedules, matched to the model.
* :mod:`bimrobot.lbd.generation`: the questions RCAN's generation system asks the graph (ready activities).
* :mod:`bimrobot.core.progress`: progress bars on stderr for long work.

See docs/lbd.md.
"""
