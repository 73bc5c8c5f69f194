from ecostudy.cli import main

main()
