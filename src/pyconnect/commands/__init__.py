"""The subcommands of ``pyconnect``: one module per command group, each with ``register()``.

A command module adds its parser to the ``pyconnect`` subparsers in ``register(commands)`` and
sets ``run=`` (a function ``(args, out, err) -> exit status``) as the parser's default;
``pyconnect.cli`` lists the modules and dispatches.
"""
