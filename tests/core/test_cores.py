"""bimrobot.core.cores: the heap kept out of full garbage collections while a job runs, blocks nesting."""

from __future__ import annotations

import gc

from bimrobot.core.cores import frozen_heap


class _Node:
    def __init__(self):
        self.me = self  # a reference cycle: only the cyclic collector frees it


def test_frozen_heap_nests_and_thaws_once_at_the_end():
    before = gc.get_freeze_count()
    with frozen_heap():
        outer = gc.get_freeze_count()
        assert outer > before  # what existed is frozen
        with frozen_heap():  # an inner block (a fork inside convert) freezes what is new ...
            pass
        assert gc.get_freeze_count() >= outer  # ... and leaves the outer block's objects frozen
    assert gc.get_freeze_count() == 0  # the outermost block thaws everything


def test_objects_made_inside_the_block_are_still_collected():
    import weakref

    with frozen_heap():
        node = _Node()
        alive = weakref.ref(node)
        del node
        gc.collect()
        assert alive() is None
