"""Hand evstar events to other event-camera libraries (imported only when used)."""
from __future__ import annotations


def to_dv_store(events):
    """The events as a dv-processing ``EventStore`` (needs ``pip install dv-processing``)."""
    try:
        import dv_processing as dv
    except ImportError:
        from .errors import BackendError

        raise BackendError("to_dv_store needs dv-processing: pip install dv-processing") from None
    store = dv.EventStore()
    push = store.push_back
    for t, x, y, p in zip(events.t.tolist(), events.x.tolist(), events.y.tolist(), events.p.tolist()):
        push(t, x, y, bool(p))
    return store
