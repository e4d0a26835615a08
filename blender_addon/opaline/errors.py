"""The one exception the add-on raises for problems the user can fix (no camera, missing
renderer, unknown preset, renderer failure). Operators and the render engine turn it into a
report; anything else is a bug and keeps its traceback."""


class OpalineError(Exception):
    pass
