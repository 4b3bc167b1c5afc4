"""The ``nlid`` command line (argparse). Entry point: :func:`nlid.cli.main.main`."""
