"""Scenes: presets as data, building a scene, scene files, physical bodies and their continuum limit,
and the ripple tank's sources, slits and screen."""

from sim.scenes.building import Scene, SceneError, build, names, scene_from_simulation

__all__ = ["Scene", "SceneError", "build", "names", "scene_from_simulation"]
