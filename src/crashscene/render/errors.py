"""The exception family of the render stage (plan, map, program, sampler).

Every message names what was wrong, where (file, field, parameter) and what
is allowed, so the CLI prints it as is.
"""
from __future__ import annotations


class RenderError(Exception):
    """A scenario cannot be rendered (or a rendered program cannot be sampled): what, where, what is allowed."""


class SampleError(RenderError):
    """A program cannot be compiled or sampled (part of the render stage's exception family)."""
