"""Exceptions raised by mjregen: each names the problem and, where it can, the fix."""


class MjregenError(Exception):
    """Base class of every error mjregen raises on purpose."""


class InvalidGridError(MjregenError, ValueError):
    """A robot grid has the wrong type, shape, border or material codes."""


class GridFileError(MjregenError, ValueError):
    """A robot file is missing, not a `.npy` file, or corrupt."""


class CheckpointError(MjregenError, ValueError):
    """An NCA checkpoint is missing, corrupt, or does not match its configuration."""


class InvalidGenomeError(MjregenError, ValueError):
    """A genome has the wrong length or holds non-finite values."""


class PhysicsParameterError(MjregenError, ValueError):
    """A material or scene parameter is missing, non-finite or out of its valid range."""


class CompileError(MjregenError, ValueError):
    """A robot cannot be compiled with the given options (e.g. empty, bad clamp index)."""


class OutputExistsError(MjregenError, FileExistsError):
    """An output file or folder exists and the caller did not ask to replace it.

    Attributes:
      path: the existing path.
    """

    def __init__(self, path: object, what: str = "replace it") -> None:
        self.path = str(path)
        super().__init__(f"{path} exists; pass overwrite=True to {what}")
