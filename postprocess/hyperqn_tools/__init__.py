"""Python tools around the hyperqn binary. Put postprocess/ on PYTHONPATH to import them (the
Makefile and the ctest Python tests do).

    paths         where the repository and the shared meshes are
    cli           the tools' bad-argument rule: one line, exit 1, output paths checked before writing
    launch        runs hyperqn (the one place that knows the binary, mpiexec and Open MPI's environment)
    decks         reads and writes decks
    output        reads an output directory: VTK frames, iterations.csv, summary.json
    compare       compares two runs vertex by vertex       (python3 -m hyperqn_tools.compare A B)
    study_report  figures and tables of `hyperqn study`    (python3 -m hyperqn_tools.study_report DIR...)
    stability     the stability suite                      (python3 -m hyperqn_tools.stability [DECK...])
    log_view      reads PETSc's -log_view: the message summary and the event lines
    sweep         a deck over a grid of values, or a set of decks, and its table
                                                           (python3 -m hyperqn_tools.sweep SWEEP.yaml)
"""
