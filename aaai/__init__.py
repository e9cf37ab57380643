"""Articulated Animal AI: a limbed agent finding food in seeded cognition test levels, on PyBullet.

Importing the package registers the Gymnasium ids (``aaai/AnimalAI-v0`` and one per level).
"""
from aaai.env import AnimalAIEnv
from aaai.registration import register_envs

__version__ = "0.1.0"
__all__ = ["AnimalAIEnv", "register_envs"]

register_envs()
