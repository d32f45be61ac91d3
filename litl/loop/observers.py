"""The observer interface as the loop sees it (`litl.observers` holds it and the observers).

Kept so that `litl.loop.observers.register`, `make`, `Observer` and `Learner` keep working.
"""

from litl.observers import Factory, Learner, Observer, ObserverContext, check_kind, make, names, register

__all__ = ["Factory", "Learner", "Observer", "ObserverContext", "check_kind", "make", "names", "register"]
