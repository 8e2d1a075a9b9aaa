from oilwatch.cli import console_main

console_main()
