"""``python -m mpsfem``: the same as the ``mpsfem`` console script."""

from mpsfem.cli import main

if __name__ == "__main__":
    raise SystemExit(main())
