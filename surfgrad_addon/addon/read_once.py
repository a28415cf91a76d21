"""Reads a request's checks and its bake share: inside a scope each thing is read once (a
rendered mesh, an image's pixels). Nothing may change what was read within the scope."""

from contextlib import contextmanager


class ReadOnce:
    """A cache that lives only inside `with scope():` (a nested scope shares the outer one);
    outside any scope every get reads anew. close(value), if given, is called on each value
    read when the outermost scope ends (a temporary file's folder)."""

    def __init__(self, close=None):
        self._cache = None
        self._close = close

    @property
    def active(self):
        return self._cache is not None

    @contextmanager
    def scope(self):
        if self._cache is not None:
            yield
            return
        self._cache = {}
        try:
            yield
        finally:
            cache, self._cache = self._cache, None
            for value in cache.values() if self._close else ():
                self._close(value)

    def get(self, key, read):
        """read(), once per key within a scope."""
        if self._cache is None:
            return read()
        if key not in self._cache:
            self._cache[key] = read()
        return self._cache[key]
