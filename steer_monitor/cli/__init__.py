"""The ``steer-monitor`` command line: one module per subcommand, each with a typed
``run(...) -> int`` and a ``register(subparsers)`` that maps argparse onto it."""

__all__: list[str] = []
