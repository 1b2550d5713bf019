from femupdate.cli import main

main()
