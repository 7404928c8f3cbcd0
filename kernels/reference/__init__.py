"""Plain numpy kernels: the executable specification every accelerated backend is tested against."""
