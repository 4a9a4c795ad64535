"""One module per subcommand; each defines register(subparsers) and keeps imports light."""
