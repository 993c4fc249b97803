"""One module per `mast-stereo` subcommand: `add_arguments(parser)` and `run(args) -> int`."""
