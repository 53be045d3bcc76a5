"""Experiments: a level's hands-on measurement that owns its parts (the computation, its operator, its
overlay and its lines in the level panels). Each module registers itself; list it in ..MODULES."""
