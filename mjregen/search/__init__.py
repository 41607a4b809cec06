"""Search: the genetic algorithm (ask/tell, never owning evaluation), evaluation backends
(serial, processes, threads, Ray), run folders that resume exactly, statistics over runs."""

BACKENDS = ("serial", "process", "thread", "ray")  # `backends.make_backend` names, cheap to import
