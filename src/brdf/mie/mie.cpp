// Lorenz-Mie theory: being written (issue 2).
