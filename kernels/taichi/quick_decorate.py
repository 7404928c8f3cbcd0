"""Imported by every module here before it decorates a kernel or func: Taichi's check of
whether a decorator sits in a class body, made cheap."""


def _quick_class_check():
    """Taichi 1.7 asks, for every @ti.kernel it decorates, whether the decorator sits in a
    class body, by inspect.getframeinfo of the caller's frame; for a kernel defined at a
    module's import that frame is importlib's (frozen: no module owns its file), so each
    call scans all of sys.modules — ~1.6 s of a warm first pipeline call with ~1,700 modules
    loaded. The same test on the frame's one source line, read by linecache."""
    import linecache
    import sys

    from taichi.lang import kernel_impl

    patterns = getattr(kernel_impl, "_KERNEL_CLASS_STACKFRAME_STMT_RES", None)
    if patterns is None or not hasattr(kernel_impl, "_inside_class"):  # another Taichi
        return

    def inside_class(level_of_class_stackframe):
        try:
            frame = sys._getframe(level_of_class_stackframe)
        except ValueError:
            return False
        line = linecache.getline(frame.f_code.co_filename, frame.f_lineno).strip()
        return any(p.match(line) for p in patterns)

    kernel_impl._inside_class = inside_class


_quick_class_check()
