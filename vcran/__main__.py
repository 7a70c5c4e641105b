from vcran.cli import console

console()
