"""The `tandem` command: one module per subcommand, wired in `app.cli.main`.

| command       | module                  |
|---------------|-------------------------|
| `scenario`    | `app.cli.scenario`      |
| `plan`        | `app.cli.plan`          |
| `check`       | `app.cli.check`         |
| `bench`       | `app.cli.benchmark`     |
| `feasibility` | `app.cli.feasibility`   |
| `dashboard`   | `app.cli.dashboard`     |
| `execute`     | `app.cli.execute`       |
| `sessions`    | `app.cli.sessions`      |

`bench` keeps its short name on the command line; its module is
`benchmark` so that "bench" in the code always means the workbench.
"""
