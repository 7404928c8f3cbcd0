"""Safe outputs: check output paths before any work, write atomically (temporary file
beside the target, renamed on success), and never overwrite an input."""
from __future__ import annotations

import contextlib
import os
import pathlib
import tempfile

from ..errors import EvstarError, OutputError


@contextlib.contextmanager
def atomic_path(path, suffix=None):
    """Yield a temporary path in the target's folder; it replaces `path` only if the block
    succeeds. An OSError (folder not creatable, disk full, no permission) is an OutputError.
    A symbolic link is followed (its target is replaced, the link kept), and a device or a
    named pipe (/dev/null, a FIFO a reader waits on) is written in place: a rename would
    put a plain file where it was."""
    path = _followed(path)
    if path.exists() and not path.is_file() and not path.is_dir():
        try:
            yield path
        except OSError as exc:
            if isinstance(exc, EvstarError):
                raise
            raise _output_error(path, exc) from None
        return
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=suffix or path.suffix + ".tmp",
                                   dir=path.parent)
        os.close(fd)
    except OSError as exc:
        raise _output_error(path, exc) from None
    try:
        yield pathlib.Path(tmp)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; give the file the usual mode
        os.replace(tmp, path)
    except OSError as exc:
        if isinstance(exc, EvstarError):
            raise
        raise _output_error(path, exc) from None
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def _followed(path):
    """`path`, a symbolic link followed to its target — but a link to what has no path
    (/dev/stdout into a pipe: /proc/self/fd/1 -> "pipe:[n]") is written through as it is."""
    if not os.path.islink(path):
        return pathlib.Path(path)
    target = pathlib.Path(os.path.realpath(path))
    return target if target.exists() or not os.path.exists(path) else pathlib.Path(path)


def _output_error(path, exc):
    return OutputError(path, f"cannot write: {exc.strerror or exc}")


def check_output_file(path, option=None):
    """OutputError unless a file can be written at `path` (checked before any work): not a
    folder (an existing one, or a path ending in a separator, which would otherwise become
    a file of the folder's name). option: the command-line option the message names."""
    text = os.fspath(path)
    path = pathlib.Path(path)
    if path.is_dir() or text.endswith(os.sep) or (os.altsep and text.endswith(os.altsep)) \
            or os.path.basename(text) in ("", ".", ".."):
        raise OutputError(text, "is a folder; give a file name" if option is None
                          else f"is a folder path; {option} needs a file name")
    _check_parent(path)
    return path


def check_new_files(paths, force):
    """OutputError for the first of `paths` (None: none) that is an existing file, unless
    `force`: the command line replaces an output file only when told (a device or named
    pipe is written, not replaced). Checked after check_outputs, whose message says more
    where the file is an input."""
    for path in paths:
        if path is not None and not force and os.path.isfile(path):
            raise OutputError(path, "exists; give --force to replace it (or another name)")


def check_output_dir(path):
    """OutputError unless `path` is, or can be made, a writable folder."""
    path = pathlib.Path(path)
    if path.exists() and not path.is_dir():
        raise OutputError(path, "exists and is not a folder; give a folder for the outputs")
    if path.is_dir():
        _probe(path, path)
        return path
    _check_parent(path)
    return path


def _check_parent(path):
    """The nearest existing ancestor must be a writable folder (the rest is created)."""
    parent = path.absolute().parent
    while not parent.exists():
        parent = parent.parent
    if not parent.is_dir():
        raise OutputError(path, f"{parent} is a file, not a folder")
    _probe(path, parent)


def _probe(path, folder):
    """Create and remove a file in `folder`: permissions alone miss read-only and virtual
    file systems, and root passes every permission check."""
    try:
        with tempfile.NamedTemporaryFile(dir=folder, prefix=".evstar-probe-"):
            pass
    except OSError as exc:
        raise OutputError(path, f"cannot create files in {folder} ({exc.strerror or exc})") from None


def check_outputs(outputs, inputs):
    """OutputError if any output path is one of the inputs (evstar never overwrites them).

    Paths are compared resolved (symlinks, `..`) and, where both exist, as the same file
    (hard links). None entries are ignored.
    """
    ins = [pathlib.Path(p) for p in inputs if p is not None]
    for out in (pathlib.Path(p) for p in outputs if p is not None):
        for src in ins:
            if _same_file(out, src):
                raise OutputError(out, f"is the input {src}; evstar never overwrites its inputs, "
                                       "choose another output")


def _same_file(a, b):
    if a.resolve() == b.resolve():
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:  # one of them does not exist yet
        return False
