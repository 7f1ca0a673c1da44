"""One module per `casewatch` subcommand. Each exposes `register(subparsers)` and `main(args)`."""
