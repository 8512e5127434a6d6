"""FMI 2.0 co-simulation slaves (pythonfmu). Inside a built FMU this package is bundled under a
versioned name with the physics core next to it as ``_bundled_core``, so that nothing collides
with a host's own imports; in the source tree the slaves use ``model_core`` directly.

Only the absence of ``_bundled_core`` itself selects the source tree: an import error inside the
bundled core (numpy or scipy missing in the host's Python) is raised as it is, so the host's log
names the module that is really missing."""
import importlib.util

if importlib.util.find_spec(__name__ + "._bundled_core") is not None:   # inside an FMU
    import pkgutil

    from . import _bundled_core as core  # type: ignore[attr-defined]

    # every FMU of a process shares this package as first imported, from the first FMU's
    # unpacked folder, which its host may delete (fmpy does after a run): import the whole
    # package now, so that no later import (another slave, a module the core imports on
    # demand) looks for a file there
    for _pkg in (core, importlib.import_module(__name__)):
        for _m in pkgutil.iter_modules(_pkg.__path__):
            if not _m.name.startswith("_"):
                importlib.import_module(f"{_pkg.__name__}.{_m.name}")
else:  # source tree / installed package
    import model_core as core

__all__ = ["core"]
