"""``python -m vecslice``: the ``vecslice`` command."""

from vecslice.cli import run

if __name__ == "__main__":
    run()
