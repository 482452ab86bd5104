"""The ``rigval`` subcommands, one module each.

Each module defines ``add_parser(subparsers)``, which registers its subcommand and sets
``func=run`` as the parser default; ``run(args) -> int`` returns the exit code. Modules import
heavy dependencies inside ``run`` so that ``rigval --help`` stays fast.
"""
