"""The subcommands of ``python -m eval``, one module each: ``add_parser(subparsers)`` adds and
returns the subcommand's parser, ``run(parser, args)`` checks what the parser cannot and does the
work. :data:`eval.__main__.COMMANDS` lists them in the order ``--help`` shows them.

* :mod:`.track`, :mod:`.compare`, :mod:`.claims`, :mod:`.suite`, :mod:`.datasets`: the
  subcommands of no paper in particular;
* ``paper_<name>``: one paper's experiments (:mod:`.paper_benchmark` and
  :mod:`.paper_estimation` for wang2023, :mod:`.paper_ho2018`, :mod:`.paper_zhao2021`,
  :mod:`.paper_zou2022`);
* :mod:`.options`: the options several subcommands share and their checks.
"""
