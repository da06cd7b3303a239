"""The one construction site and the one fleet: the site file (yard, homes, model offset, calendar),
the fleet file (robots, capabilities, speeds) with its built-in fleets (``site/fleets/*.yaml``), and the
``bimrobot fleet`` command. Units: metres, seconds, kg; z up, the site frame.
"""
