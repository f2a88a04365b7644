"""Settings the user gave in the environment, read when jaxbelt is imported, before it imports JAX (which
gives ``TF_CPP_MIN_LOG_LEVEL`` a default of its own when it loads). Read only; nothing is changed here."""

import os

# the user chose XLA's C++ log level: the command line keeps it (cli/compile_notice.py). True as well when
# JAX was imported before jaxbelt (its default then looks given: the command line leaves it alone)
XLA_LOG_LEVEL_GIVEN = "TF_CPP_MIN_LOG_LEVEL" in os.environ
