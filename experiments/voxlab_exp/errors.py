"""The two exceptions the experiment scripts turn into exit statuses (cli.main_wrapper).

Exists so that every module can raise them without importing the module that catches them:
VoxlabError exits 1 (a voxlab call or the environment failed), DeclarationError exits 2 (the
declaration cannot be run as written; its message names the file and the field).
"""


class VoxlabError(Exception):
    pass


class DeclarationError(VoxlabError):
    """A declared experiment that cannot be run as written (the message names the file and field)."""
