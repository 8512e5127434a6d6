"""FMI 2.0 co-simulation slaves (pythonfmu). Inside a built FMU this package is bundled under a
versioned name with the physics core next to it as ``_bundled_core``, so that nothing collides
with a host's own imports; in the source tree the slaves use ``model_core`` directly."""
try:  # inside an FMU
    from . import _bundled_core as core  # type: ignore[attr-defined]
except ImportError:  # source tree / installed package
    import model_core as core

__all__ = ["core"]
