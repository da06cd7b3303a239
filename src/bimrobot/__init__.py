"""bimrobot: from a building information model (IFC) to robot worlds, smart construction objects,
the RCAN middle layer and DRL assembly planning.

Conventions used everywhere: lengths in metres, z up, masses in kg, times in seconds; an element is
identified by its IFC GlobalId.
"""

__version__ = "0.1.0"
