"""Imported (by this package's __init__ and evstar.backends) before Taichi is: Taichi's check
of whether a decorator sits in a class body, made cheap — for Taichi's own ~90 kernels and
functions, decorated while `import taichi` runs, and for ours."""
import inspect
import linecache
import sys


def _frame_line(frame, context=1):
    """inspect.getframeinfo's answer with the frame's one source line read by linecache: the
    only part Taichi's class-body test reads (code_context)."""
    name = frame.f_code.co_filename
    return inspect.Traceback(name, frame.f_lineno, frame.f_code.co_name,
                             [linecache.getline(name, frame.f_lineno)], 0)


def _import_taichi():
    """Taichi 1.7 asks, for every @ti.kernel and @ti.func it decorates, whether the decorator
    sits in a class body, by inspect.getframeinfo of the caller's frame; for a kernel defined
    at a module's import that frame is importlib's (frozen: no module owns its file), so each
    call scans all of sys.modules (~1,700 once scikit-learn, scipy and matplotlib are loaded).
    `import taichi` alone decorates ~90: 0.4 → 0.07 s with getframeinfo answered from
    linecache while it runs."""
    if "taichi" in sys.modules:
        return
    slow = inspect.getframeinfo
    inspect.getframeinfo = _frame_line
    try:
        import taichi  # noqa: F401
    finally:
        inspect.getframeinfo = slow


def _quick_class_check():
    """Our decorators after the import: the same test on the frame's one source line."""
    from taichi.lang import kernel_impl

    patterns = getattr(kernel_impl, "_KERNEL_CLASS_STACKFRAME_STMT_RES", None)
    if patterns is None or not hasattr(kernel_impl, "_inside_class"):  # another Taichi
        return

    def inside_class(level_of_class_stackframe):
        try:
            frame = sys._getframe(level_of_class_stackframe)
        except ValueError:
            return False
        line = _frame_line(frame).code_context[0].strip()
        return any(p.match(line) for p in patterns)

    kernel_impl._inside_class = inside_class


_import_taichi()
_quick_class_check()
