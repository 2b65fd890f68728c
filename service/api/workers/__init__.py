"""The work the API schedules off the serving process (the physics it runs is in
`service.dynamics`; the processes it runs in are `service.processes`'s).

    equations        the derivation of the equations in explicit form in a child process,
                     with a time limit (`derive_isolated`)
    equations_cache  each robot's equations, in memory and on disk, derived once
                     (`EquationsCache`, on `app.state.equations`)
    identification   `identify` in a long-lived worker process, one fit at a time, with a
                     time limit (`IdentificationWorker`, on `app.state.identification`)
"""
