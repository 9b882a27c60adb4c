from checker.cli.entry import main

main()
