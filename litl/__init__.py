"""litl: learning-in-the-loop co-design of soft robots with differentiable MPM."""

__version__ = "0.1.0"
