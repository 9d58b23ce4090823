"""Real water: the model against measured data (NOMAD, COPS casts, camera photos); REALWATER.md
(``python -m experiments.realwater``, ``make real-data``)."""

__all__: list[str] = []
