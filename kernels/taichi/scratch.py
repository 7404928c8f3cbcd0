"""Scratch arrays with an owner: kept zeroed between the owner's calls, freed on release.

The kernels leave their grids, tiles and planes all zero when a call completes, so a filter
keeps them for its next call instead of allocating (and zeroing) them again. A call that
stops part-way (an exception, KeyboardInterrupt between two launches) can leave them dirty:
the owner then drops them, and the next call starts from fresh zeros.
"""
import threading


class Scratch:
    """One owner's scratch arrays. Wrap each call in `with scratch:`; calls take turns."""

    def __init__(self):
        self._arrays = {}  # name -> (key, array)
        self._lock = threading.Lock()
        self._dirty = False

    def __enter__(self):
        self._lock.acquire()
        if self._dirty:  # the last call did not finish: its arrays may hold its frames
            self._arrays.clear()
        self._dirty = True
        return self

    def __exit__(self, kind, value, traceback):
        self._dirty = kind is not None
        self._lock.release()

    def array(self, name, key, make):
        """The array called `name`, made by make() when missing or made for another key."""
        held = self._arrays.get(name)
        if held is None or held[0] != key:
            self._arrays[name] = held = (key, make())
        return held[1]

    @property
    def dirty(self):
        """True after a call that did not finish (its arrays are dropped on the next call)."""
        return self._dirty

    def arrays(self):
        """The arrays held now, by name."""
        return {name: arr for name, (_, arr) in self._arrays.items()}

    def release(self):
        """Free every array (waits for a running call to end)."""
        with self._lock:
            self._arrays.clear()
            self._dirty = False

    def __reduce__(self):  # copies and pickles of the owner start with no arrays
        return Scratch, ()
