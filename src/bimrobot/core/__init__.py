"""What every part of bimrobot uses, and which imports no other part: the one error type (exit 2),
the one output policy (atomic writes, markers), configuration files and their declarative schema,
cores and forked children, rotations, construction task kinds, safe names, the forked process pool
and progress bars.

Nothing in ``core`` imports from another ``bimrobot`` folder; everything else may import from it.
"""
