"""python3 -m methods_bench: the command line of bench_methods.sh (see main.py)."""

from .main import main

main()
